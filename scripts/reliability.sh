#!/usr/bin/env bash
# The reliability checks (issue 12, docs/reliability.md), on the build `setup.sh --sanitize` makes
# in <build>/sanitize. Any sanitizer report, fuzzer finding, Valgrind error or leak in our FMUs
# fails the script.
#   1. the whole CTest suite built with AddressSanitizer + UndefinedBehaviorSanitizer;
#   2. each shipped FMU's libFuzzer harness for ANKLEHIP_FUZZ_SECONDS (default 60) from the
#      committed seed corpus (fmu/fuzz/corpus), leaks and slow inputs (> 10 s) included;
#   3. closed-loop scenarios from Python through the sanitized FMUs (ASan runtime preloaded): the
#      sagittal loop (hip_saves_push) and the 3D ones (side_push_frontal, and step_recovery_3d with
#      the stepping layer: AnkleHipController3D on Hoap2Plant3D), so every shipped FMU runs sanitized;
#   4. a Valgrind memcheck of the same closed loops through the shipped FMUs, and of the
#      controller's FMI 3.0 Scheduled Execution variant and the 3D plant's FMI 3.0 arrays (the known
#      errors of the interpreter, NumPy, lxml and the loader suppressed by scripts/valgrind-python.supp).
# Usage: bash scripts/reliability.sh            (after bash scripts/setup.sh --sanitize)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${ANKLEHIP_BUILD_DIR:-build}"
sbuild="$build/sanitize"
seconds="${ANKLEHIP_FUZZ_SECONDS:-60}"
[ -f "$sbuild/CMakeCache.txt" ] || { echo "reliability: no sanitizer build in $sbuild (bash scripts/setup.sh --sanitize)" >&2; exit 1; }
asan_rt="$(clang -print-file-name=libclang_rt.asan-x86_64.so)"
# Every report is fatal; the symbolizer makes the stacks readable.
export ASAN_OPTIONS="abort_on_error=1:detect_leaks=1:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export ASAN_SYMBOLIZER_PATH="${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer || true)}"

echo "== 1/4 CTest, sanitized"
ctest --test-dir "$sbuild" --output-on-failure --no-tests=error -j"$(nproc)"

echo "== 2/4 FMI fuzzing, ${seconds} s per FMU"
# the corpus under build/sanitize/fuzz grows across runs on this machine; the seeds are the committed ones
bash scripts/fuzz.sh "$seconds" "$sbuild/fuzz"

echo "== 3/4 closed loops through the sanitized FMUs from Python"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
# The interpreter's own allocations at exit are not ours: leak checking is the fuzzers' and
# Valgrind's job here; every other report aborts the run.
for scenario in hip_saves_push side_push_frontal step_recovery_3d; do
  if ! ANKLEHIP_FMU_DIR="$root/$sbuild/fmus" LD_PRELOAD="$asan_rt" ASAN_OPTIONS="abort_on_error=1:detect_leaks=0" \
      .venv/bin/anklehip run "$scenario" --out "$out/$scenario" --no-progress >"$out/$scenario.log" 2>&1; then
    tail -n 60 "$out/$scenario.log"
    echo "reliability: the sanitized closed loop $scenario failed" >&2
    exit 1
  fi
  if grep -Eq 'AddressSanitizer|runtime error|LeakSanitizer' "$out/$scenario.log"; then
    cat "$out/$scenario.log"; echo "reliability: sanitizer report in the closed loop $scenario" >&2; exit 1
  fi
  echo "   $scenario: $(grep -Eo "scenario $scenario: [^(]*" "$out/$scenario.log" | head -n1)"
done

echo "== 4/4 Valgrind memcheck of the closed loops"
# Four single-threaded runs at once, each report printed whole and in order (81, 46, 36 and 54 s
# one after the other on the 2-core machine); the stepping loop to 3 s takes the recovery step and
# the closing step's swing; the --fmi3-extras run is the FMI 3.0 paths the loops do not take:
# Scheduled Execution and the 3D plant's arrays.
vg_args=("hip_saves_push --stop-time 1.5" "side_push_frontal --stop-time 1.5" "--fmi3-extras"
         "step_recovery_3d --stop-time 3")
vg_pids=()
for i in "${!vg_args[@]}"; do
  # shellcheck disable=SC2086  # each entry is the script's arguments, split on purpose
  .venv/bin/python scripts/valgrind_closed_loop.py ${vg_args[$i]} >"$out/valgrind-$i.log" 2>&1 & vg_pids+=($!)
done
vg_failed=0
for i in "${!vg_args[@]}"; do
  wait "${vg_pids[$i]}" || vg_failed=1
  cat "$out/valgrind-$i.log"
done
[ "$vg_failed" -eq 0 ] || { echo "reliability: Valgrind found an error or a leak in our FMUs (above)" >&2; exit 1; }
echo "reliability: all checks passed"
