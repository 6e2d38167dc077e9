#!/usr/bin/env bash
# Runs the libFuzzer targets of tests/fuzz/ side by side for SECONDS each (make fuzz-smoke,
# make fuzz). Usage: scripts/fuzz.sh BUILD_DIR SECONDS TARGET...
# Each target starts from its seed corpus tests/fuzz/corpus/<target>/ (and for model files,
# matrices, samples and waypoint files the shipped and test ones) and grows its own copy in
# BUILD_DIR/corpus/<target>/ (kept between runs). A crash, sanitizer report, leak, hang
# (> 20 s for one input) or memory blow-up (> 4 GB) is saved as BUILD_DIR/findings/<target>-*
# and fails the run; to keep it as a regression test, copy it to tests/fuzz/regressions/<target>/.
# libFuzzer stops at its first finding; with FUZZ_KEEP_GOING=1 (make fuzz) each target runs in
# fork mode instead, saves every finding and goes on for the whole time.
set -uo pipefail
cd "$(dirname "$0")/.."
build_dir=$1 seconds=$2
shift 2
export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0"
rm -rf "$build_dir/findings"  # this run's findings only: keep the ones that matter as regressions
mkdir -p "$build_dir/findings"
# More seeds, read but not grown: the shipped models, the test models, matrices and trajectory
# files (not the demo's solves: a megabyte each, they would slow every mutation). Every target
# has a folder, if an empty one.
rm -rf "$build_dir/seeds"
for target in "$@"; do mkdir -p "$build_dir/seeds/$target"; done
mkdir -p "$build_dir/seeds/model_file" "$build_dir/seeds/matrix_market" \
  "$build_dir/seeds/trajectory_file" "$build_dir/seeds/waypoint_file"
cp models/*.yaml tests/data/*.yaml tests/data/linear/*.yaml "$build_dir/seeds/model_file/"
cp tests/data/linear/*.mtx "$build_dir/seeds/matrix_market/"
cp tests/data/errors/samples_*.csv "$build_dir/seeds/trajectory_file/"
cp tests/data/errors/waypoints_*.yaml "$build_dir/seeds/waypoint_file/"
keep_going=()
if [ "${FUZZ_KEEP_GOING:-0}" = 1 ]; then
  keep_going=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
fi
pids=()
for target in "$@"; do
  mkdir -p "$build_dir/corpus/$target"
  "$build_dir/tests/fuzz/fuzz_$target" "$build_dir/corpus/$target" "tests/fuzz/corpus/$target" \
    "$build_dir/seeds/$target" \
    -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$build_dir/findings/$target-" "${keep_going[@]}" \
    >"$build_dir/fuzz-$target.log" 2>&1 &
  pids+=($!)
done
failed=0
for i in "${!pids[@]}"; do
  target=${*:i+1:1}
  wait "${pids[$i]}"
  status=$?
  found=$(ls "$build_dir/findings/$target"-* 2>/dev/null | grep -v slow-unit | wc -l)
  if [ $status -eq 0 ] && [ "$found" -eq 0 ]; then
    runs=$(grep -oE '^#[0-9]+' "$build_dir/fuzz-$target.log" | tail -1 | tr -d '#')
    coverage=$(grep -o 'cov: [0-9]*' "$build_dir/fuzz-$target.log" | tail -1)
    echo "fuzz $target: ${seconds} s, ${runs:-?} inputs, ${coverage:-cov: ?}, no findings"
  else
    echo "fuzz $target: $found finding(s) in $build_dir/findings (log: $build_dir/fuzz-$target.log):" >&2
    grep -E "ERROR|SUMMARY|Test unit written|terminate called|what\(\)" \
      "$build_dir/fuzz-$target.log" | head -8 >&2
    failed=1
  fi
done
exit $failed
