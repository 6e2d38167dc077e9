#!/usr/bin/env bash
# Side-by-side: parameter sweep of the mass on car (alpha x d) by servokit and by the SciPy
# peer (bench/scipy_sweep.py: linearization, Rosenbrock pencil QZ, Markov parameters, per point).
#
# Usage: bench/compare_sweep.sh [BUILD_DIR]      (default: build)
# Environment: SCIPY_GRID (default 100: 100 x 100 points, enough for a stable rate),
#              SERVOKIT_GRID (default 1000: 1000 x 1000 = 1e6 points),
#              THREADS (default: nproc), PYTHON (default /usr/bin/python3, Debian's, with SciPy).
# servokit is timed with `date +%s.%N` around the whole command (start-up, model load and
# CSV writing included); SciPy reports its own loop time (CSV writing included, imports not).
# If `servokit sweep` does not exist yet, says so after the SciPy part and exits 0.
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
scipy_grid=${SCIPY_GRID:-100}
servokit_grid=${SERVOKIT_GRID:-1000}
threads=${THREADS:-$(nproc)}
servokit="$build/application/servokit"
model="$root/models/mass_on_car.yaml"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

rows=()  # "tool points seconds"

json_field() {  # json_field FIELD < json
  "$python" -c 'import json, sys; print(json.loads(sys.stdin.readline())[sys.argv[1]])' "$1"
}

echo "== sweep: mass on car, alpha = 0..90 deg x d = 0..2 =="
echo "scipy: $python $root/bench/scipy_sweep.py --alpha-points $scipy_grid --d-points $scipy_grid"
scipy_json=$("$python" "$root/bench/scipy_sweep.py" --alpha-points "$scipy_grid" \
  --d-points "$scipy_grid" --out "$work/scipy_points.csv")
scipy_points=$(json_field points <<<"$scipy_json")
scipy_seconds=$(json_field seconds <<<"$scipy_json")
rows+=("scipy $scipy_points $scipy_seconds")

print_table() {
  local scipy_rate
  scipy_rate=$(awk -v p="$scipy_points" -v s="$scipy_seconds" 'BEGIN { print p / s }')
  printf '%-22s %10s %10s %12s %10s\n' tool points seconds points/s "x SciPy"
  local row tool points seconds
  for row in "${rows[@]}"; do
    read -r tool points seconds <<<"$row"
    awk -v t="$tool" -v p="$points" -v s="$seconds" -v r="$scipy_rate" \
      'BEGIN { printf "%-22s %10d %10.3f %12.0f %10.1f\n", t, p, s, p / s, (p / s) / r }'
  done
}

if [[ ! -x "$servokit" ]]; then
  print_table
  echo "servokit: $servokit not found (build it first: make build); only the SciPy part ran"
  exit 0
fi
# CLI11 prints the top-level help even for an unknown subcommand, so look for it in the list.
if ! "$servokit" --help 2>/dev/null | grep -qE '^[[:space:]]+sweep([[:space:]]|$)'; then
  print_table
  echo "servokit: '$servokit sweep' is not available yet; only the SciPy part ran"
  exit 0
fi

run_servokit() {  # run_servokit THREADS
  local n=$1 out="$work/servokit_$1" start end
  echo "servokit: $servokit sweep $model --vary alpha=0deg:90deg:$servokit_grid" \
    "--vary d=0:2:n=$servokit_grid --out $out --threads $n"
  start=$(date +%s.%N)
  if ! "$servokit" sweep "$model" --vary "alpha=0deg:90deg:$servokit_grid" \
      --vary "d=0:2:n=$servokit_grid" --out "$out" --threads "$n" >"$work/servokit_$n.log"; then
    echo "compare_sweep: servokit sweep --threads $n failed; its output:" >&2
    cat "$work/servokit_$n.log" >&2
    exit 1
  fi
  end=$(date +%s.%N)
  local points=$((servokit_grid * servokit_grid))
  local lines
  lines=$(($(wc -l <"$out/points.csv") - 1))
  if ((lines != points)); then
    echo "compare_sweep: $out/points.csv has $lines rows, expected $points" >&2
    exit 1
  fi
  rows+=("servokit-threads-$n $points $(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')")
  rm -rf "$out"
}

run_servokit 1
if ((threads != 1)); then run_servokit "$threads"; fi
print_table
