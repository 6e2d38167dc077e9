#!/usr/bin/env bash
# Side-by-side (issue #32, a closed chain's solve): the feedforward of the gantry crane in
# absolute coordinates, its rope a loop constraint, by `servokit solve
# models/gantry_crane_absolute.yaml` (the whole command: start-up, model load, the loops as servo
# constraints, the symbolic structure with its dynamic extension, 4001 rows written) and by
# NumPy (bench/numpy_crane_absolute.py: the closed form from the load's equations, written by
# hand, alone and as `python3 script.py`); the two agree at t = 1 s (F, W and the rope force).
# The same crane in minimal coordinates (models/gantry_crane.yaml) is timed beside it: what
# the loop costs.
#
# Usage: bench/compare_crane_absolute.sh [BUILD_DIR]     (default: build)
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
motion=(--trajectory rest-to-rest --y0 0,2 --yf 1,2 --t0 0 --tf 3 --t-end 4 --sample-time 0.001)
loops=$(best_of "$build/application/servokit" solve "$root/models/gantry_crane_absolute.yaml" \
  "${motion[@]}" --out "$out/loops.csv")
minimal=$(best_of "$build/application/servokit" solve "$root/models/gantry_crane.yaml" \
  "${motion[@]}" --out "$out/minimal.csv")
numpy_whole=$(best_of "$python" "$root/bench/numpy_crane_absolute.py")
numpy=$("$python" "$root/bench/numpy_crane_absolute.py")
"$python" - "$loops" "$minimal" "$numpy_whole" "$numpy" "$out/loops.csv" <<'PY'
import csv, json, sys
loops, minimal, whole = (float(x) for x in sys.argv[1:4])
peer = json.loads(sys.argv[4])
with open(sys.argv[5]) as f:
    row = next(r for r in csv.DictReader(f) if abs(float(r["t"]) - 1.0) < 1e-12)
difference = max(abs(float(row["F"]) - peer["F"]), abs(float(row["W"]) - peer["W"]),
                 abs(float(row["lambda1"]) - peer["lambda"]))
print(f"servokit solve, crane in absolute coordinates (whole command) {1e3 * loops:8.1f} ms")
print(f"servokit solve, crane in minimal coordinates (whole command)  {1e3 * minimal:8.1f} ms")
print(f"NumPy closed form, python3 script (whole process)             {1e3 * whole:8.1f} ms"
      f"   ratio {whole / loops:.1f}")
print(f"NumPy closed form alone                                       {1e3 * peer['seconds']:8.2f} ms")
print(f"largest difference of F, W, lambda at t = 1 s: {difference:.2e}")
PY
