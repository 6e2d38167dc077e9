#!/usr/bin/env bash
# Side-by-side (issue #19): a parameter sweep of the shipped models and of the closed chains of
# the tests (issue #32: five-bar, crane in absolute coordinates, the redundant rotational arm,
# Andrews' squeezing mechanism) by servokit and
# by the generic per-point SciPy pipeline of bench/scipy_generic_sweep.py (the model file's
# expressions compiled with sympy; per point: operating point, complex-step linearization,
# Rosenbrock pencil QZ, Markov parameters, verdict), over the same grid, in one run.
#
# Usage: bench/compare_generic_sweep.sh [BUILD_DIR]      (default: build)
# Environment: GRID (default 200: GRID x GRID points per model), REPEAT (default 3: servokit's
#              time is the least of REPEAT runs),
#              MODELS (default: all nine), PYTHON (default /usr/bin/python3, Debian's, with
#              SciPy, SymPy and PyYAML),
#              BEFORE (optional: another build directory, e.g. of an earlier commit, whose
#              servokit is timed on the same grids in the same run: column "before x").
# Both are measured in CPU time, one thread: servokit `sweep --threads 1` as the whole command
# (user + system; start-up, model load and compilation, the sweep and its CSV files, fsync);
# the SciPy peer its own loop (time.process_time, CSV writing included; not the interpreter
# start-up, the imports nor the compilation of the model's expressions), with
# OPENBLAS_NUM_THREADS=1. The peer then checks every point's classes and zeros against
# servokit's tables (exit 1 on a mismatch).
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
grid=${GRID:-200}
repeat=${REPEAT:-3}
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
models=${MODELS:-"mass_on_car rotational_arm three_link_arm mass_spring_chain gantry_crane five_bar gantry_crane_absolute rotational_arm_redundant andrews_squeezer"}

before=""
if [[ -n ${BEFORE:-} ]]; then before="$(cd "$BEFORE" && pwd)/application/servokit"; fi

if [[ ! -x "$servokit" ]]; then
  echo "servokit: $servokit not found (build it first: make build)"
  exit 1
fi

# The two varied parameters of each model: a physically meaningful range of each.
axes() {
  case $1 in
    mass_on_car) echo "alpha=0deg:90deg:$grid d=0:2:n=$grid" ;;
    rotational_arm) echo "s=0.1:2:n=$grid d=0:1:n=$grid" ;;
    three_link_arm) echo "c=10:100:n=$grid d=0:1:n=$grid" ;;
    mass_spring_chain) echo "m=0.5:2:n=$grid k=50:200:n=$grid" ;;
    gantry_crane) echo "m=1:10:n=$grid L0=1:5:n=$grid" ;;
    # Closed chains (issue #32): classified on the tangent space of c(q) = 0.
    five_bar) echo "c=5:20:n=$grid d=0.05:0.5:n=$grid" ;;
    gantry_crane_absolute) echo "m=1:10:n=$grid L0=1:5:n=$grid" ;;
    rotational_arm_redundant) echo "s=0.1:2:n=$grid d=0:1:n=$grid" ;;
    andrews_squeezer) echo "c0=3000:6000:n=$grid l0=0.07:0.085:n=$grid" ;;
    *) echo "compare_generic_sweep: no grid for model $1" >&2; exit 1 ;;
  esac
}

# A shipped model, or a closed chain of the tests (tests/data/loops).
model_file() {
  if [[ -f "$root/models/$1.yaml" ]]; then echo "$root/models/$1.yaml"
  else echo "$root/tests/data/loops/$1.yaml"; fi
}

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export OPENBLAS_NUM_THREADS=1

rows=()
for model in $models; do
  read -r first second <<<"$(axes "$model")"
  vary=(--vary "$first" --vary "$second")
  echo "== $model: $first x $second =="
  # cpu_seconds BINARY OUT: CPU time (user + system) of a whole one-thread sweep into OUT, the
  # least of REPEAT runs (a fraction of a second each, where one busy moment of a shared
  # machine shows; the peer's long loop averages such moments out).
  cpu_seconds() {
    local best="" times seconds
    for ((run = 0; run < repeat; ++run)); do
      rm -rf "$2"
      times=$( { TIMEFORMAT='%3U %3S'; time "$1" sweep "$(model_file "$model")" "${vary[@]}" \
        --out "$2" --threads 1 >"$work/log" 2>&1; } 2>&1) || {
        echo "compare_generic_sweep: $1 sweep of $model failed; its output:" >&2
        cat "$work/log" >&2
        exit 1
      }
      seconds=$(awk '{ print $1 + $2 }' <<<"$times")
      best=$(awk -v a="$seconds" -v b="${best:-$seconds}" 'BEGIN { print (a < b) ? a : b }')
    done
    echo "$best"
  }
  out="$work/servokit-$model"
  servokit_seconds=$(cpu_seconds "$servokit" "$out")
  before_seconds=0
  if [[ -n $before ]]; then
    before_seconds=$(cpu_seconds "$before" "$work/before-$model")
    rm -rf "$work/before-$model"
  fi
  points=$(($(wc -l <"$out/points.csv") - 1))
  scipy_json=$("$python" "$root/bench/scipy_generic_sweep.py" "$(model_file "$model")" \
    "${vary[@]}" --out "$work/scipy-$model" --check "$out")
  scipy_seconds=$("$python" -c 'import json, sys; print(json.loads(sys.stdin.readline())["seconds"])' \
    <<<"$scipy_json")
  rows+=("$model $points $scipy_seconds $servokit_seconds $before_seconds")
  rm -rf "$out" "$work/scipy-$model"
done

echo
printf '%-18s %8s %12s %12s %14s %14s %9s' model points "SciPy CPU s" "servokit s" \
  "SciPy pts/s" "servokit pts/s" "x SciPy"
if [[ -n $before ]]; then printf ' %10s %9s' "before s" "before x"; fi
echo
for row in "${rows[@]}"; do
  read -r model points scipy servokit_s before_s <<<"$row"
  awk -v m="$model" -v p="$points" -v a="$scipy" -v b="$servokit_s" -v c="$before_s" \
    -v show="${before:+1}" 'BEGIN {
    printf "%-18s %8d %12.3f %12.3f %14.0f %14.0f %9.1f", m, p, a, b, p / a, p / b, a / b
    if (show) printf " %10.3f %9.1f", c, a / c
    printf "\n" }'
done
