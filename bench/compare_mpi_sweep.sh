#!/usr/bin/env bash
# MPI efficiency of `servokit sweep` (issue #6): one sweep on 1 rank x 1 thread and on 2 ranks
# x 1 thread each (`mpirun -np 2 servokit sweep --threads 1`), the files compared byte for byte.
# Efficiency = T1 / (2 T2), with T1 the plain single process (no mpirun: the launcher's start-up
# counts against MPI) and, for reference, T1 under `mpirun -np 1` too.
#
# Usage: bench/compare_mpi_sweep.sh [BUILD_DIR]      (default: build)
# Environment: MODEL (default tests/data/chain_output_x3.yaml: the six-mass chain observed at its
#              third mass, six zero-dynamics eigenvalues a point), VARY (default
#              "m=0.5:2:n=600 k=50:150:n=600": 360 000 points, about 15 s on one thread here),
#              REPEAT (default 3: the best of REPEAT runs of each), MPIRUN (default mpirun).
# Each run is timed with `date +%s.%N` around the whole command (start-up, MPI_Init, model load,
# CSV writing and the final fsync included).
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
model=${MODEL:-$root/tests/data/chain_output_x3.yaml}
read -r -a vary_values <<<"${VARY:-m=0.5:2:n=600 k=50:150:n=600}"
repeat=${REPEAT:-3}
mpirun=${MPIRUN:-mpirun}

if [[ ! -x "$servokit" ]]; then
  echo "servokit: $servokit not found (build it first)"
  exit 1
fi
if ! command -v "$mpirun" >/dev/null; then
  echo "mpirun: $mpirun not found (apt-get install openmpi-bin)"
  exit 1
fi
# Open MPI refuses to run as root unless told; --oversubscribe lets 2 ranks run on fewer cores.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mpi=("$mpirun" -q --oversubscribe)

vary=()
for value in "${vary_values[@]}"; do vary+=(--vary "$value"); done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# best_time NAME COMMAND...: runs COMMAND REPEAT times in $work/NAME with --out out (the same
# relative --out for every run, so that sweep.json, which records the command line, is the same
# too) and prints the shortest wall time in seconds.
best_time() {
  local name=$1 best="" start end seconds
  shift
  mkdir -p "$work/$name"
  for ((i = 0; i < repeat; ++i)); do
    rm -rf "${work:?}/$name/out"
    start=$(date +%s.%N)
    (cd "$work/$name" && "$@" --out out >"$work/$name.stdout")
    end=$(date +%s.%N)
    seconds=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')
    if [[ -z "$best" ]] || awk -v s="$seconds" -v b="$best" 'BEGIN { exit !(s < b) }'; then
      best=$seconds
    fi
  done
  echo "$best"
}

sweep=("$servokit" sweep "$model" "${vary[@]}" --threads 1)

echo "== MPI sweep efficiency: $(basename "$model"), ${vary_values[*]}, best of $repeat =="
echo "$(nproc) cores; $("$mpirun" --version | head -n 1); load average before: $(cut -d ' ' -f 1-3 /proc/loadavg)"
t1=$(best_time one "${sweep[@]}")
t1_mpi=$(best_time one_mpi "${mpi[@]}" -np 1 "${sweep[@]}")
t2=$(best_time two "${mpi[@]}" -np 2 "${sweep[@]}")
points=$(awk '{ print $2 }' "$work/one.stdout")  # "swept N points of ..."

for name in one_mpi two; do
  for table in points.csv eigenvalues.csv sweep.json; do
    if ! cmp -s "$work/one/out/$table" "$work/$name/out/$table"; then
      echo "FAIL: $name/$table differs from the single-process run"
      exit 1
    fi
  done
done

printf '%-34s %8s %10s %12s %11s\n' run ranks seconds points/s efficiency
row() {  # row LABEL RANKS SECONDS
  awk -v l="$1" -v r="$2" -v s="$3" -v t1="$t1" -v p="$points" \
    'BEGIN { printf "%-34s %8d %10.3f %12.0f %10.1f%%\n", l, r, s, p / s, 100 * t1 / (r * s) }'
}
row "servokit (1 process, 1 thread)" 1 "$t1"
row "mpirun -np 1 (1 thread)" 1 "$t1_mpi"
row "mpirun -np 2 (1 thread per rank)" 2 "$t2"
echo "load average after: $(cut -d ' ' -f 1-3 /proc/loadavg) (other work on the machine skews T2 most)"
echo "files of all three runs identical, byte for byte; efficiency = T1 / (ranks x T)," \
  "T1 = the plain process"
