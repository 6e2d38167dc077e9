#!/usr/bin/env bash
# `servokit sweep --threads 2` against `--threads 1` on every shipped model (issue #19), on the
# machine as it is and with one competing busy process (a shell loop on one core, as another
# user's job would be): two threads must never be slower than one, and on an idle machine
# should be at least 1.5 times as fast where points are cheap.
#
# Usage: bench/compare_threads.sh [BUILD_DIR]      (default: build)
# Environment: REPEAT (default 3: the best of 3 runs, alternating 1 and 2 threads),
#              SCALE (default 1: multiplies every grid's size).
# Each grid is sized so that one thread takes about a second. Times are wall times of the whole
# command (start-up, writing and the final fsync included). ratio = t(1 thread) / t(2 threads):
# above 1, two threads are faster.
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
repeat=${REPEAT:-3}
scale=${SCALE:-1}

work=$(mktemp -d)
competitor=""
cleanup() {
  [[ -n "$competitor" ]] && kill "$competitor" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# model file and grid (one --vary each) per shipped model: about a second on one thread.
cases=(
  "mass_on_car.yaml alpha=1deg:90deg:n=$((1000 * scale)) d=0:2:n=1000"
  "rotational_arm.yaml s=0:2:n=$((1000 * scale)) d=0.05:1:n=1000"
  "three_link_arm.yaml d=0.05:1:n=$((1000 * scale)) c=10:100:n=300"
  "gantry_crane.yaml m=1:20:n=$((1000 * scale)) L0=1:5:n=250"
  "mass_spring_chain.yaml k=10:200:n=$((1000 * scale)) m=0.5:2:n=200"
)

best_time() {  # best_time THREADS MODEL VARY...: best wall seconds of $repeat runs
  local threads=$1 model=$2
  shift 2
  local vary=() best=""
  for v in "$@"; do vary+=(--vary "$v"); done
  for ((i = 0; i < repeat; ++i)); do
    rm -rf "$work/out"
    local start end t
    start=$(date +%s.%N)
    "$servokit" sweep "$root/models/$model" "${vary[@]}" --threads "$threads" \
      --out "$work/out" >/dev/null 2>&1
    end=$(date +%s.%N)
    t=$(echo "$end - $start" | bc -l)
    if [[ -z "$best" ]] || (($(echo "$t < $best" | bc -l))); then best=$t; fi
  done
  printf "%.3f" "$best"
}

run_all() {  # run_all LABEL
  for case in "${cases[@]}"; do
    read -r model vary1 vary2 <<<"$case"
    points=$(( $(echo "$vary1" | sed 's/.*n=//') * $(echo "$vary2" | sed 's/.*n=//') ))
    t1=$(best_time 1 "$model" "$vary1" "$vary2")
    t2=$(best_time 2 "$model" "$vary1" "$vary2")
    printf "%-10s %-24s %9d | %8s %8s | %5.2f\n" "$1" "$model" "$points" "$t1" "$t2" \
      "$(echo "$t1 / $t2" | bc -l)"
  done
}

printf "%-10s %-24s %9s | %8s %8s | %5s\n" machine model points 1_thread 2_threads ratio
run_all as-is
bash -c 'while :; do :; done' &
competitor=$!
run_all busy+1
