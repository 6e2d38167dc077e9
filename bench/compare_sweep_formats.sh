#!/usr/bin/env bash
# `servokit sweep --format csv` against `--format hdf5` and `--format mat` (issue #17): the same
# sweep of the mass on car, one thread, each format run REPEAT times in turn (csv, hdf5, mat,
# csv, ...) so that a busy machine slows all of them alike; prints the best wall time of each and
# the speed-up over CSV. The HDF5 and MAT files are checked to hold as many points as the CSV.
#
# Usage: bench/compare_sweep_formats.sh [BUILD_DIR]      (default: build)
# Environment: GRID (default 1000: alpha = 0.01..1.5 rad x d = 0..2, GRID x GRID points),
#              MAT_GRID (default 300: MAT 5 is built in memory and is slow for 10^6 points; 0
#              skips it), REPEAT (default 3), PYTHON (default /usr/bin/python3, with h5py).
# Each run is timed by bash's `time` around the whole command (start-up, model load, writing and
# the final fsync included): wall time, and CPU time (user + system), which a busy machine
# disturbs less; the best of REPEAT runs of each is shown, with the speed-up over CSV.
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
model="$root/models/mass_on_car.yaml"
grid=${GRID:-1000}
mat_grid=${MAT_GRID:-300}
repeat=${REPEAT:-3}
python=${PYTHON:-/usr/bin/python3}

if [[ ! -x "$servokit" ]]; then
  echo "servokit: $servokit not found (build it first)"
  exit 1
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# seconds FORMAT N: one sweep of N x N points in FORMAT into $work/FORMAT-N; prints its wall
# time and its CPU time (user + system), in seconds.
seconds() {
  local format=$1 n=$2 out="$work/$1-$2" times
  rm -rf "$out"
  local TIMEFORMAT='%3R %3U %3S'
  if ! times=$( { time "$servokit" sweep "$model" --vary "alpha=0.5:86:n=$n" --vary "d=0:2:n=$n" \
      --out "$out" --format "$format" --threads 1 >"$work/log" 2>&1; } 2>&1); then
    echo "compare_sweep_formats: servokit sweep --format $format failed; its output:" >&2
    cat "$work/log" >&2
    exit 1
  fi
  awk '{ printf "%.3f %.3f\n", $1, $2 + $3 }' <<<"$times"
}

# rows OUT FORMAT: the number of rows of the points table in OUT.
rows() {
  case $2 in
    csv) echo $(($(wc -l <"$1/points.csv") - 1)) ;;
    hdf5) "$python" -c 'import h5py, sys; print(len(h5py.File(sys.argv[1])["points/error"]))' \
      "$1/sweep.h5" ;;
    mat) "$python" -c 'import scipy.io, sys; print(scipy.io.loadmat(sys.argv[1])["points"]["d"][0, 0].size)' \
      "$1/sweep.mat" ;;
  esac
}

min() { awk -v a="$1" -v b="$2" 'BEGIN { print (b == "" || a < b) ? a : b }'; }

compare() {  # compare N FORMAT...: best times of each format on N x N points, and x CSV
  local n=$1 format wall cpu
  shift
  declare -A best=() best_cpu=()
  for ((i = 0; i < repeat; ++i)); do
    for format in "$@"; do
      read -r wall cpu <<<"$(seconds "$format" "$n")"
      best[$format]=$(min "$wall" "${best[$format]:-}")
      best_cpu[$format]=$(min "$cpu" "${best_cpu[$format]:-}")
    done
  done
  for format in "$@"; do
    local expected=$((n * n)) got
    got=$(rows "$work/$format-$n" "$format")
    if ((got != expected)); then
      echo "compare_sweep_formats: --format $format wrote $got points, expected $expected" >&2
      exit 1
    fi
  done
  printf '%-8s %10s %8s %8s %8s %8s %6s\n' format points wall "x CSV" cpu "x CSV" MB
  for format in "$@"; do
    local megabytes
    megabytes=$(du -sm "$work/$format-$n" | cut -f1)
    awk -v f="$format" -v p="$((n * n))" -v s="${best[$format]}" -v c="${best[csv]}" \
      -v u="${best_cpu[$format]}" -v uc="${best_cpu[csv]}" -v m="$megabytes" \
      'BEGIN { printf "%-8s %10d %8.3f %8.2f %8.3f %8.2f %6d\n", f, p, s, c / s, u, uc / u, m }'
  done
}

echo "== sweep formats: mass on car, $grid x $grid points, one thread, best of $repeat =="
compare "$grid" csv hdf5
if ((mat_grid > 0)); then
  echo
  echo "== with MAT 5: $mat_grid x $mat_grid points, one thread, best of $repeat =="
  compare "$mat_grid" csv hdf5 mat
fi
