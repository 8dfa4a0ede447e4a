#!/usr/bin/env bash
# Run the libFuzzer FMI harness of each named FMU (docs/reliability.md section 1) for SECONDS,
# from the committed seeds plus the corpus under WORK (which grows across runs), and print the
# figures: inputs executed, inputs per second, edges covered, corpus size. Any crash, sanitizer
# report, leak or input slower than 10 s fails the script and leaves the input in WORK/findings/.
# Usage: bash scripts/fuzz.sh SECONDS WORK [FMU...]   (default: every shipped FMU; needs the
#        build of `bash scripts/setup.sh --sanitize`)
#   bash scripts/fuzz.sh 60 build/sanitize/fuzz                                   # the CI step
#   bash scripts/fuzz.sh 1200 /tmp/campaign AnkleHipController Hoap2Plant          # a longer campaign
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
[ $# -ge 2 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
seconds="$1"; work="$2"; shift 2
fmus=("$@"); [ ${#fmus[@]} -gt 0 ] || fmus=(AnkleHipController Hoap2Plant Hoap2Plant3D)
sbuild="${ANKLEHIP_BUILD_DIR:-build}/sanitize"
asan_rt="$(clang -print-file-name=libclang_rt.asan-x86_64.so)"
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export ASAN_SYMBOLIZER_PATH="${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer || true)}"
for fmu in "${fmus[@]}"; do
  exe="$(find "$sbuild/fmu" -name "${fmu}_fuzz" -type f | head -n1)"
  [ -x "$exe" ] || { echo "fuzz: ${fmu}_fuzz not built in $sbuild (bash scripts/setup.sh --sanitize)" >&2; exit 1; }
  corpus="$work/corpus-$fmu"
  mkdir -p "$corpus" "$work/findings"
  log="$work/$fmu.log"
  if ! LD_PRELOAD="$asan_rt" "$exe" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
      -artifact_prefix="$work/findings/$fmu-" "$corpus" fmu/fuzz/corpus >"$log" 2>&1; then
    tail -n 60 "$log"
    echo "fuzz: the $fmu fuzzer found a defect (input in $work/findings/)" >&2
    exit 1
  fi
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")"
  cov="$(grep -Eo 'cov: [0-9]+' "$log" | tail -n1)"
  echo "   $fmu: $runs inputs ($rate/s), ${cov#cov: } edges, corpus $(ls "$corpus" | wc -l) inputs, no finding"
done
