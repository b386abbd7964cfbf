#!/usr/bin/env bash
# Runs each libFuzzer target for SECONDS on its seed corpus (`make fuzz`, docs/testing.md).
#   tests/fuzz/run.sh BIN_DIR WORK_DIR SECONDS TARGET...
# New interesting inputs go to WORK_DIR/corpus/<target> (the seeds in git stay as they are);
# a crash, sanitizer report, leak, hang (> 10 s for one input) or allocation above 2 GB leaves
# WORK_DIR/artifacts/<target>-* and makes this script exit 1 after all targets ran. Except for
# the hdf5 target: libhdf5 1.10 itself crashes, over-reads, allocates without bound and loops on
# damaged files, so that target keeps going after a failure and each saved input whose report
# starts inside libhdf5 (crash_origin.py) is accepted if BIN_DIR/wm-ingest, which reads HDF5 in
# a limited child process, turns it into a clean error (exit 1). Anything else fails the run.
set -uo pipefail
bin=$1 work=$2 seconds=$3
shift 3
here="$(cd "$(dirname "$0")" && pwd)"
export LSAN_OPTIONS="suppressions=$here/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
failed=()

# Accepts a saved hdf5 input when its report starts inside libhdf5 and wm-ingest reports it as
# an error; prints the verdict.
judge_hdf5_failure() {
  local input=$1 origin report ingest_out
  report=$(ASAN_OPTIONS="allocator_may_return_null=1:max_allocation_size_mb=2048" \
    timeout 120 "$bin/fuzz_hdf5" -timeout=10 -rss_limit_mb=2048 "$input" 2>&1)
  origin=$(/usr/bin/python3 "$here/crash_origin.py" <<< "$report")
  if [[ "$origin" != libhdf5* ]]; then
    echo "fuzz: hdf5: FAILURE IN WMKIT ($origin): $input"
    return 1
  fi
  if [ ! -x "$bin/wm-ingest" ]; then
    echo "fuzz: hdf5: libhdf5-internal failure, unchecked (no $bin/wm-ingest): $input"
    return 1
  fi
  cp "$input" "$work/judge.hdf5"
  ingest_out=$(timeout 300 "$bin/wm-ingest" --format hdf5 --input "$work/judge.hdf5" \
    --output "$work/judge-out" --hdf5-memory-limit-mb 1024 --hdf5-cpu-limit-s 30 \
    --log-level warn 2>&1)
  local rc=$?
  rm -rf "$work/judge.hdf5" "$work/judge-out"
  if [ "$rc" -gt 1 ] || { [ "$rc" -eq 1 ] && [[ "$ingest_out" != *"wm-ingest: error: "* ]]; }; then
    echo "fuzz: hdf5: libhdf5-internal failure that wm-ingest does not contain (exit $rc): $input"
    echo "$ingest_out" | tail -n 3
    return 1
  fi
  echo "fuzz: hdf5: libhdf5-internal failure, contained by wm-ingest (exit $rc): $input"
}

for target in "$@"; do
  mkdir -p "$work/corpus/$target" "$work/artifacts"
  log="$work/$target.log"
  echo "fuzz: $target for ${seconds}s (log: $log)"
  asan_options=${ASAN_OPTIONS:-}
  extra=()
  if [ "$target" = hdf5 ]; then
    # libhdf5 1.10 mallocs a variable-length string's stored length unchecked, so C malloc above
    # 2 GB returns NULL here as it would on a real machine (wmkit's own C++ allocations above
    # 2 GB still fail). Its other failures are saved and judged below.
    asan_options="allocator_may_return_null=1:max_allocation_size_mb=2048"
    extra=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
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
  if [ "$target" = hdf5 ]; then
    status=0
    grep -q "INFO: fuzzed for" "$log" || status=1  # the fork-mode driver itself ended early
    for input in "$work/artifacts/hdf5"-*; do
      [ -e "$input" ] || continue
      judge_hdf5_failure "$input" || status=1
    done
  fi
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
