#!/usr/bin/env bash
# The two commands of the project (see README.md):
#   bash run.sh main   set everything up, build, run the paper's five-push experiment
#   bash run.sh test   set everything up, build, run the whole test suite (CTest + pytest)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$root"
case "${1:-}" in
  main)
    bash scripts/setup.sh
    .venv/bin/anklehip run paper_five_pushes --out results/paper_five_pushes --plots
    ;;
  test)
    # The suite includes the Windows binaries under Wine (tests/test_win64.py) and the aarch64
    # ones under qemu-user (tests/test_aarch64.py), and the fmi-sim importer (tests/test_fmi_sim.py):
    # build them, and fail rather than skip if any piece is missing. pytest spreads the test files over
    # the cores (pytest-xdist). Then the reliability checks on the sanitizer
    # build: sanitized CTest, FMI fuzzing, a sanitized closed loop, Valgrind (docs/reliability.md).
    bash scripts/setup.sh --win64 --sanitize --aarch64 --fmi-sim
    export PATH="$root/.venv/bin:$PATH" ANKLEHIP_REQUIRE_WIN64=1 ANKLEHIP_REQUIRE_AARCH64=1 ANKLEHIP_REQUIRE_FMI_SIM=1
    ctest --test-dir "${ANKLEHIP_BUILD_DIR:-build}" --output-on-failure --no-tests=error
    .venv/bin/python -m pytest -q -n auto --dist loadfile tests
    bash scripts/reliability.sh
    ;;
  *)
    echo "usage: bash run.sh main|test" >&2; exit 2 ;;
esac
