#!/usr/bin/env bash
# Runs each libFuzzer target for SECONDS on its seed corpus (`make fuzz`, docs/testing.md).
#   tests/fuzz/run.sh BIN_DIR WORK_DIR SECONDS TARGET...
# New interesting inputs go to WORK_DIR/corpus/<target> (the seeds in git stay as they are);
# a crash, sanitizer report, leak, hang (> 10 s for one input) or allocation above 2 GB leaves
# WORK_DIR/artifacts/<target>-* and makes this script exit 1 after all targets ran.
set -uo pipefail
bin=$1 work=$2 seconds=$3
shift 3
here="$(cd "$(dirname "$0")" && pwd)"
export LSAN_OPTIONS="suppressions=$here/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
failed=()
for target in "$@"; do
  mkdir -p "$work/corpus/$target" "$work/artifacts"
  log="$work/$target.log"
  echo "fuzz: $target for ${seconds}s (log: $log)"
  asan_options=${ASAN_OPTIONS:-}
  extra=()
  if [ "$target" = hdf5 ]; then
    # Two libhdf5 1.10 bugs, not wmkit's (docs/testing.md): it mallocs a variable-length
    # string's stored length unchecked, so C malloc above 2 GB returns NULL here as it would on
    # a real machine (wmkit's own C++ allocations above 2 GB still fail), and a damaged global
    # heap can make it loop forever, so hangs are saved and listed but do not fail the run.
    asan_options="allocator_may_return_null=1:max_allocation_size_mb=2048"
    extra=(-fork=1 -ignore_timeouts=1)
  fi
  ASAN_OPTIONS=$asan_options "$bin/fuzz_$target" "${extra[@]}" -max_total_time="$seconds" \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$work/artifacts/$target-" "$work/corpus/$target" "$here/corpus/$target" \
    > "$log" 2>&1
  status=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  [ -z "$runs" ] && runs=$(grep -o '^#[0-9]*' "$log" | tail -1 | tr -d '#')  # -fork prints no stats
  echo "fuzz: $target exit $status, ${runs:-?} inputs run," \
    "corpus $(ls "$work/corpus/$target" | wc -l) files"
  for hang in "$work/artifacts/$target"-timeout-*; do
    [ "$target" = hdf5 ] && [ -e "$hang" ] && echo "fuzz: hdf5: known libhdf5 hang saved: $hang"
  done
  if [ "$status" -ne 0 ]; then
    failed+=("$target")
    grep -m2 -E 'terminate called|what\(\)|runtime error|ERROR: (AddressSanitizer|libFuzzer|LeakS)' \
      "$log"
  fi
done
if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: FAILED: ${failed[*]} (inputs in $work/artifacts; see docs/testing.md)"
  exit 1
fi
echo "fuzz: all targets passed"
