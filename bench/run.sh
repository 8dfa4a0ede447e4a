#!/usr/bin/env bash
# All benchmarks in one run (figures, not pass/fail): the controller tick (C), the 3D plant on ODE
# and the closed loop on it, the FMPy closed loop's per-step split, then bench/report.py: the sagittal plant with both
# integrators, the closed loop on the FMPy master and on the native engine, the peers (FMPy's
# simulate_fmu, a container FMU, the Rust fmi-sim crate) and scaling: a table on stdout and
# bench/results.json (docs/performance.md).
#   bash bench/run.sh            (after bash scripts/setup.sh)
# fmi-sim is installed once from crates.io with cargo when it is missing (its build needs Debian's
# libclang-dev, installed here when running as root); without cargo the peer is reported missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${ANKLEHIP_BUILD_DIR:-$root/build}"
py="$root/.venv/bin/python"
cmake --build "$build" --target controller_step_bench plant_bench plant3d_bench anklehip_closed_loop >/dev/null
echo "== controller: ahc_step (C99 library), 20 passes over an 8 s sequence through all phases"
"$build/bench/controller_step_bench" 20
echo
echo "== 3D plant: Hoap2Plant3D model on ODE, 1 ms communication steps, configurations side by side"
"$build/plant3d/plant3d_bench"
echo
echo "== closed loop on the 3D plant: paper_five_pushes, native engine and FMPy master, as shipped and as before"
"$py" "$root/bench/closed_loop_3d_bench.py"
echo
echo "== closed loop, FMPy master: where a step's time goes (paper_five_pushes, 20 s)"
"$py" "$root/bench/closed_loop_bench.py" paper_five_pushes --stop-time 20
echo

fmisim="$(command -v fmi-sim || true)"
[ -n "$fmisim" ] || [ ! -x "$HOME/.cargo/bin/fmi-sim" ] || fmisim="$HOME/.cargo/bin/fmi-sim"
if [ -z "$fmisim" ]; then
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
