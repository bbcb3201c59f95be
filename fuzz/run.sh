#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs every built fuzz target for SECONDS seconds each: fuzz/run.sh BUILD_DIR SECONDS [TARGET...]
# Seeds are read from fuzz/corpus/<target>/ (never written); new inputs go to BUILD_DIR/corpus/<target>/, crashes to
# BUILD_DIR/crashes/. Prints libFuzzer's final stats per target and a summary line; exits non-zero if any target fails.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-fuzz}
seconds=${2:-30}
shift 2 || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in "$build"/fuzz/fuzz_*; do [ -x "$f" ] && targets+=("$(basename "$f")"); done
fi
mkdir -p "$build/crashes" "$build/fuzz-logs"
status=0
printf '%-22s %12s %10s %8s %8s %8s\n' target executions exec/s cov ft seconds
for t in "${targets[@]}"; do
  work="$build/corpus/$t"
  mkdir -p "$work" "fuzz/corpus/$t"
  log="$build/fuzz-logs/$t.log"
  # -timeout: one input taking > 10 s is a hang; -rss_limit_mb / -malloc_limit_mb: a hostile input must not make us
  # allocate more than this (see docs/hardening.md, memory bounds).
  # Per-target flags (e.g. a tighter -malloc_limit_mb for readers that promise bounded allocation): fuzz/<t>.options.
  extra=()
  [ -f "fuzz/$t.options" ] && read -r -a extra <"fuzz/$t.options"
  start=$(date +%s)
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    timeout -k 10 $((seconds + 120)) "$build/fuzz/$t" "$work" "fuzz/corpus/$t" -max_total_time="$seconds" \
    -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 -print_final_stats=1 \
    -artifact_prefix="$build/crashes/$t-" "${extra[@]}" >"$log" 2>&1
  rc=$?
  end=$(date +%s)
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$')
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+')
  ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+')
  printf '%-22s %12s %10s %8s %8s %8s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" $((end - start))
  if [ $rc -ne 0 ]; then
    echo "FAIL: $t exited with $rc; log: $log" >&2
    grep -E 'ERROR|SUMMARY|fuzz_|Test unit written' "$log" | head -20 >&2
    status=1
  fi
done
exit $status
