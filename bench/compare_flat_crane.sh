#!/usr/bin/env bash
# Side-by-side: the flat inverse of a linear double-pendulum crane (relative degree 6) by
# `servokit solve --method algebraic` (the whole command: start-up, model load, symbolic
# derivation, 4001 rows written) and by NumPy (bench/numpy_flat_crane.py: the hand-written
# inverse alone, and `python3 script.py` as a whole). Goal: servokit under 0.1 s.
#
# Usage: bench/compare_flat_crane.sh [BUILD_DIR]     (default: build)
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

best_of() {  # best wall time of 5 runs of "$@", in seconds
  local best=1e9
  for _ in 1 2 3 4 5; do
    local start end
    start=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    end=$(date +%s.%N)
    best=$("$python" -c "print(min($best, $end - $start))")
  done
  echo "$best"
}
servokit=$(best_of "$build/application/servokit" solve "$root/tests/data/linear_double_pendulum_crane.yaml" \
  --trajectory rest-to-rest --y0 0 --yf 1 --t0 0 --tf 3 --t-end 4 --method algebraic \
  --out "$out/u.csv")
numpy_whole=$(best_of "$python" "$root/bench/numpy_flat_crane.py")
numpy_inverse=$("$python" "$root/bench/numpy_flat_crane.py")
"$python" - "$servokit" "$numpy_whole" "$numpy_inverse" <<'PY'
import json, sys
servokit, whole = float(sys.argv[1]), float(sys.argv[2])
inverse = json.loads(sys.argv[3])["seconds"]
print(f"servokit solve --method algebraic (whole command)   {1e3 * servokit:8.1f} ms   (goal: under 100 ms)")
print(f"NumPy flat inverse, python3 script (whole process)  {1e3 * whole:8.1f} ms   ratio {whole / servokit:.1f}")
print(f"NumPy flat inverse alone                             {1e3 * inverse:8.2f} ms")
PY
