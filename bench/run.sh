#!/usr/bin/env bash
# All benchmarks in one run (figures, not pass/fail): the controller tick (C), the plant's CVODE
# integration (C++), the 3D plant on ODE, and the FMPy closed loop with its per-step cost split plant/controller/glue.
#   bash bench/run.sh            (after bash scripts/setup.sh)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${ANKLEHIP_BUILD_DIR:-$root/build}"
cmake --build "$build" --target controller_step_bench plant_bench plant3d_bench >/dev/null
echo "== controller: ahc_step (C99 library), 20 passes over an 8 s sequence through all phases"
"$build/bench/controller_step_bench" 20
echo
echo "== plant: Hoap2Plant model + CVODE, 1 ms communication steps"
"$build/plant/plant_bench"
echo
echo "== 3D plant: Hoap2Plant3D model on ODE, 1 ms communication steps, internal step side by side"
"$build/plant3d/plant3d_bench"
echo
echo "== closed loop: FMPy master, both FMUs, paper_five_pushes"
"$root/.venv/bin/python" "$root/bench/closed_loop_bench.py" paper_five_pushes --stop-time 20
