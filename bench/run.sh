#!/usr/bin/env bash
# All benchmarks in one run (figures, not pass/fail): the controller tick (C), the 3D plant on ODE
# and the closed loop on it, the FMPy closed loop's per-step split, then bench/report.py: the sagittal plant with both
# integrators, the closed loop on the FMPy master and on the native engine, the peers (FMPy's
# simulate_fmu, a container FMU, the Rust fmi-sim crate) and scaling: a table on stdout and
# bench/results.json (docs/performance.md).
#   bash bench/run.sh            (after bash scripts/setup.sh)
#   bash bench/run.sh --quick --out DIR/results.json
#                                every benchmark in its quick mode (short runs, one repetition): what
#                                the test suite runs (tests/test_benchmarks.py) so that no benchmark
#                                rots; its figures are not the ones to quote. --out: where report.py
#                                writes its JSON (default bench/results.json).
# fmi-sim is installed once from crates.io with cargo when it is missing (its build needs Debian's
# libclang-dev, installed here when running as root); without cargo the peer is reported missing.
# The quick mode installs nothing: it uses an fmi-sim that is there (<build>/fmi-sim, PATH, ~/.cargo).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${ANKLEHIP_BUILD_DIR:-$root/build}"
py="$root/.venv/bin/python"
quick=0
if [ "${1:-}" = "--quick" ]; then quick=1; fi
cmake --build "$build" --target controller_step_bench leg_ik_bench plant_bench plant3d_bench anklehip_closed_loop >/dev/null
passes=20; [ "$quick" -eq 1 ] && passes=1
echo "== controller: ahc_step (C99 library), $passes passes over an 8 s sequence through all phases"
"$build/bench/controller_step_bench" "$passes"
echo
echo "== leg IK: the closed-form kinematics of a leg for any foot pose (controller_c leg_ik.h)"
"$build/bench/leg_ik_bench" "$passes"
echo
echo "== 3D plant: Hoap2Plant3D model on ODE, 1 ms communication steps, configurations side by side"
"$build/plant3d/plant3d_bench"
echo
echo "== closed loop on the 3D plant: paper_five_pushes, native engine and FMPy master, as shipped and as before"
if [ "$quick" -eq 1 ]; then "$py" "$root/bench/closed_loop_3d_bench.py" --repeat 1; else "$py" "$root/bench/closed_loop_3d_bench.py"; fi
echo
echo "== closed loop, FMPy master: where a step's time goes (paper_five_pushes, 20 s)"
if [ "$quick" -eq 1 ]; then
  "$py" "$root/bench/closed_loop_bench.py" paper_five_pushes --quick
else
  "$py" "$root/bench/closed_loop_bench.py" paper_five_pushes --stop-time 20
fi
echo

fmisim=""
[ ! -x "$build/fmi-sim/bin/fmi-sim" ] || fmisim="$build/fmi-sim/bin/fmi-sim"
[ -n "$fmisim" ] || fmisim="$(command -v fmi-sim || true)"
[ -n "$fmisim" ] || [ ! -x "$HOME/.cargo/bin/fmi-sim" ] || fmisim="$HOME/.cargo/bin/fmi-sim"
if [ -z "$fmisim" ] && [ "$quick" -eq 0 ]; then
  cargo="$(command -v cargo || true)"
  [ -n "$cargo" ] || [ ! -x "$HOME/.cargo/bin/cargo" ] || cargo="$HOME/.cargo/bin/cargo"
  if [ -n "$cargo" ]; then
    if ! dpkg-query -W -f='${Status}' libclang-dev 2>/dev/null | grep -q "install ok installed"; then
      if [ "$(id -u)" -eq 0 ]; then
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libclang-dev >/dev/null
      else
        echo "bench: fmi-sim needs libclang-dev to build (apt-get install libclang-dev)" >&2
      fi
    fi
    echo "== installing the fmi-sim crate (once): cargo install fmi-sim"
    "$cargo" install fmi-sim --quiet || echo "bench: cargo install fmi-sim failed: that peer is skipped" >&2
    [ -x "$HOME/.cargo/bin/fmi-sim" ] && fmisim="$HOME/.cargo/bin/fmi-sim"
  else
    echo "bench: cargo not found: the fmi-sim peer is skipped" >&2
  fi
fi
echo "== plant, closed loop, peers, scaling (bench/report.py)"
"$py" "$root/bench/report.py" ${fmisim:+--fmi-sim "$fmisim"} "$@"
