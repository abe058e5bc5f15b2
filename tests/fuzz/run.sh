#!/usr/bin/env bash
# Runs the libFuzzer targets of a fuzz build: tests/fuzz/run.sh BIN_DIR SECONDS [TARGET...]
# Each target starts from its seed corpus and past findings (tests/fuzz/corpus/NAME,
# tests/fuzz/regressions/NAME) plus what earlier runs found (build/fuzz/corpus/NAME, kept between
# runs), under a memory limit: a crash, a sanitizer report, a leak, an input that takes more than
# 10 s or asks for more than 1 GiB is a finding. Findings are written to build/fuzz/findings/NAME/.
# Prints one line of figures per target; exits 1 when any target found anything.
set -uo pipefail
BIN=$1
SECONDS_EACH=$2
shift 2
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
OUT=$ROOT/build/fuzz
JOBS=${PL_JOBS:-$(nproc 2>/dev/null || echo 2)}
RSS_MB=${PL_FUZZ_RSS_MB:-1024}

targets=("$@")
if [[ ${#targets[@]} -eq 0 ]]; then
  for f in "$BIN"/fuzz_*; do targets+=("$(basename "$f" | sed 's/^fuzz_//')"); done
fi
for t in "${targets[@]}"; do
  [[ -x "$BIN/fuzz_$t" ]] || { echo "no fuzz target \"$t\" (have: $(ls "$BIN" | sed -n 's/^fuzz_//p' | tr '\n' ' '))" >&2; exit 2; }
done

run_one() {
  local t=$1 work=$OUT/corpus/$1 findings=$OUT/findings/$1 log=$OUT/logs/$1.log
  mkdir -p "$work" "$findings" "$OUT/logs"
  rm -f "$findings"/*
  local dict=()
  [[ -f "$ROOT/tests/fuzz/$t.dict" ]] && dict=(-dict="$ROOT/tests/fuzz/$t.dict")
  # libFuzzer writes new inputs to the first folder only: the repository's corpus stays as it is.
  # It refuses a folder that does not exist, and git keeps no empty folder: pass only those there.
  local seeds=()
  for d in "$ROOT/tests/fuzz/corpus/$t" "$ROOT/tests/fuzz/regressions/$t"; do [[ -d "$d" ]] && seeds+=("$d"); done
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
    "$BIN/fuzz_$t" -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb="$RSS_MB" -malloc_limit_mb="$RSS_MB" \
      -print_final_stats=1 -artifact_prefix="$findings/" "${dict[@]}" \
      "$work" "${seeds[@]}" >"$log" 2>&1
  echo $? >"$log.rc"
}
export -f run_one
export BIN OUT ROOT SECONDS_EACH RSS_MB

printf '%s\n' "${targets[@]}" | xargs -P "$JOBS" -I{} bash -c 'run_one {}'

failed=0
printf '%-16s %12s %9s %7s %7s %8s  %s\n' target executions exec/s cov ft corpus result
for t in "${targets[@]}"; do
  log=$OUT/logs/$t.log
  rc=$(cat "$log.rc" 2>/dev/null || echo 99)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p' <<<"$last")
  found=$(ls "$OUT/findings/$t" 2>/dev/null | wc -l)
  result=ok
  if [[ "$rc" != 0 || "$found" != 0 ]]; then
    failed=1
    kind=$(grep -oE 'ERROR: (libFuzzer|AddressSanitizer|LeakSanitizer): [a-z-]+|runtime error|out-of-memory|timeout' "$log" | head -1)
    result="FINDING (${kind:-exit $rc}): $(ls "$OUT/findings/$t" | head -3 | tr '\n' ' ') log $log"
  fi
  printf '%-16s %12s %9s %7s %7s %8s  %s\n' "$t" "${execs:-?}" "${speed:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$result"
done
if [[ $failed -ne 0 ]]; then
  echo "fuzzing found problems: reproduce one with $BIN/fuzz_TARGET FILE; once fixed, add the input to tests/fuzz/regressions/TARGET/" >&2
fi
exit $failed
