#!/usr/bin/env bash
# Run the libFuzzer FMI harness of each FMU (docs/reliability.md section 1) and print its figures:
# inputs executed and per second, edges covered, corpus size, the deep programs' successful steps
# per program, and the coverage of our sources (functions and edges reached, by folder, from
# libFuzzer's -print_coverage over the final corpus). Every input starts from the committed seeds
# plus the corpus under WORK (which grows across runs). Any crash, sanitizer report, leak, input
# slower than 10 s or oracle finding (a restored state that does not continue bit for bit, an
# accepted forged state that misbehaves) fails the script and leaves the input in WORK/findings/.
# Usage:
#   bash scripts/fuzz.sh SECONDS WORK [FMU...]     SECONDS per FMU (default FMUs: every shipped FMU
#                                                 whose <Model>_fuzz is built in <build>/sanitize;
#                                                 each covers the FMU and its FMI 3.0 twin)
#   bash scripts/fuzz.sh --long WORK [FMU...]      until 10 million inputs per FMU (days: the 3D
#                                                 plant runs about 15 inputs/s sanitized); RUNS=N
#                                                 sets another count; the figures also go to
#                                                 WORK/figures.md, to be quoted in docs/reliability.md
#   bash scripts/fuzz.sh 60 build/sanitize/fuzz   (the CI step; needs bash scripts/setup.sh --sanitize)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
long=0
if [ "${1:-}" = "--long" ]; then long=1; shift; fi
if [ "$long" -eq 1 ]; then
  [ $# -ge 1 ] || { sed -n '2,20p' "$0" >&2; exit 2; }
  work="$1"; shift
  limit=(-runs="${RUNS:-10000000}")
else
  [ $# -ge 2 ] || { sed -n '2,20p' "$0" >&2; exit 2; }
  seconds="$1"; work="$2"; shift 2
  limit=(-max_total_time="$seconds")
fi
sbuild="${ANKLEHIP_BUILD_DIR:-build}/sanitize"
fmus=("$@")
if [ ${#fmus[@]} -eq 0 ]; then
  # every shipped FMU (the ones packed into <build>/sanitize/fmus; not the glue's test model)
  while IFS= read -r f; do
    m="$(basename "$f" _fuzz)"
    [ ! -f "$sbuild/fmus/$m.fmu" ] || fmus+=("$m")
  done < <(find "$sbuild/fmu" -name '*_fuzz' -type f | sort)
fi
[ ${#fmus[@]} -gt 0 ] || { echo "fuzz: no <Model>_fuzz built in $sbuild (bash scripts/setup.sh --sanitize)" >&2; exit 1; }
asan_rt="$(clang -print-file-name=libclang_rt.asan-x86_64.so)"
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export ASAN_SYMBOLIZER_PATH="${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer || true)}"
mkdir -p "$work/findings"
figures="$work/figures.md"
[ "$long" -eq 1 ] && printf '| FMU | inputs | per second | edges | corpus | deep programs | successful steps per program | functions reached |\n|---|---|---|---|---|---|---|---|\n' >"$figures"
# One FMU: its fuzzer, then the coverage of its final corpus (every function of ours the inputs
# reach); the fuzzer's exit status and wall time go to files for the report.
fuzz_one() {
  local fmu="$1" exe="$2" corpus log t0 rc=0
  corpus="$work/corpus-$fmu"
  log="$work/$fmu.log"
  mkdir -p "$corpus"
  t0=$(date +%s)
  LD_PRELOAD="$asan_rt" "$exe" "${limit[@]}" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$work/findings/$fmu-" "$corpus" fmu/fuzz/corpus >"$log" 2>&1 || rc=$?
  echo $(( $(date +%s) - t0 )) >"$work/$fmu.wall"
  echo "$rc" >"$work/$fmu.status"
  [ "$rc" -ne 0 ] || LD_PRELOAD="$asan_rt" "$exe" -runs=0 -print_coverage=1 "$corpus" fmu/fuzz/corpus \
    >"$work/$fmu.coverage" 2>&1 || true
}
exes=()
for fmu in "${fmus[@]}"; do
  exe="$(find "$sbuild/fmu" -name "${fmu}_fuzz" -type f | head -n1)"
  [ -x "$exe" ] || { echo "fuzz: ${fmu}_fuzz not built in $sbuild (bash scripts/setup.sh --sanitize)" >&2; exit 1; }
  exes+=("$exe")
done
# As many fuzzers at once as there are cores (each is one single-threaded process with a core to
# itself), reported in the FMUs' order.
jobs="$(nproc)"
for ((first = 0; first < ${#fmus[@]}; first += jobs)); do
  batch=("${fmus[@]:first:jobs}")
  pids=()
  for ((i = first; i < first + ${#batch[@]}; ++i)); do fuzz_one "${fmus[$i]}" "${exes[$i]}" & pids+=($!); done
  wait "${pids[@]}"
  for fmu in "${batch[@]}"; do
    if [ "$(cat "$work/$fmu.status")" -ne 0 ]; then
      tail -n 60 "$work/$fmu.log"
      echo "fuzz: the $fmu fuzzer found a defect (input in $work/findings/)" >&2
      exit 1
    fi
    extra=()
    [ "$long" -eq 0 ] || extra=(--figures "$figures")
    .venv/bin/python scripts/fuzz_report.py "$fmu" "$work/$fmu.log" "$work/$fmu.coverage" "$work/corpus-$fmu" \
      "$(cat "$work/$fmu.wall")" "${extra[@]}"
  done
done
[ "$long" -eq 0 ] || echo "figures: $figures"
