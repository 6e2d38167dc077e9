#!/usr/bin/env bash
# Byte-identical outputs, before and after a change that must not change behaviour (issue #16):
# runs the same commands (analyze, sweep, threshold, solve, report, generate) on the shipped
# models with two servokit executables and compares what each prints on stdout and stderr,
# its exit status and every file it writes, byte for byte. Exits 0 when all agree, 1 naming
# each difference.
#   scripts/compare-outputs.sh OLD_SERVOKIT NEW_SERVOKIT
# e.g. build the commit before the change into another folder and compare with this build:
#   git worktree add /tmp/before <commit> && make -C /tmp/before build
#   scripts/compare-outputs.sh /tmp/before/build/application/servokit build/application/servokit
# (a build from before the application folder existed has its executable in build/reports/).
set -uo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 OLD_SERVOKIT NEW_SERVOKIT" >&2
  exit 2
fi
old=$(realpath "$1")
new=$(realpath "$2")
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Both runs see the same paths: each runs inside $work/run, which is renamed to its side after.
models="$root/models"
data="$root/tests/data"

# The commands, one per line; OUT stands for a fresh output folder of the command, GEN for the
# folder of the generated models, which later commands read.
commands() {
  for model in "$models"/*.yaml; do
    for format in text json md; do echo "analyze $model --format $format"; done
  done
  echo "analyze $models/mass_on_car.yaml --set alpha=5deg --set d=0 --format json"
  echo "analyze $models/rotational_arm.yaml --set s=1 --format json"
  echo "analyze $data/pvtol.yaml --format json"
  echo "generate chain --masses 300 --out GEN/chain"
  echo "generate beam --elements 40 --out GEN/beam"
  echo "analyze GEN/chain/chain_300.yaml --format json"
  echo "analyze GEN/chain/chain_300.yaml --eigen-solver arpack --eigenvalues 6 --format text"
  echo "analyze GEN/beam/beam_40.yaml --format md"
  echo "sweep $models/mass_on_car.yaml --vary alpha=0deg:90deg:19 --vary d=0:2:5 --out OUT/sweep"
  echo "sweep $models/rotational_arm.yaml --vary s=0:1:n=21 --threads 2 --out OUT/arm-sweep"
  echo "sweep GEN/chain/chain_300.yaml --vary d=0.01,0.1 --out OUT/chain-sweep"
  echo "threshold $models/mass_on_car.yaml --vary alpha=1deg:80deg --event oscillation --set d=1"
  echo "threshold $models/mass_on_car.yaml --vary alpha=1deg:89deg --event realization"
  echo "threshold $models/rotational_arm.yaml --vary s=0:1 --event stability"
  echo "threshold $models/three_link_arm.yaml --vary l=0.5:2 --event stability"
  local rest="--trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10"
  echo "solve $models/mass_on_car.yaml --set alpha=0 --set d=0 $rest --sample-time 0.01 --verify --out OUT/case4.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=0 $rest --sample-time 0.01 --verify --out OUT/case2.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=0 --set d=1 $rest --verify --out OUT/case3.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method radau --out OUT/case2-radau.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method bdf --out OUT/case2-bdf.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method euler --step 0.01 --out OUT/case2-euler.csv"
  echo "solve $models/rotational_arm.yaml --set s=1 --trajectory rest-to-rest --y0 0 --yf 270deg --t0 1 --tf 3 --t-end 4 --method stable-inversion --sample-time 0.01 --verify --out OUT/arm.csv"
  echo "solve $models/three_link_arm.yaml --trajectory rest-to-rest --y0 0 --yf 1 --t0 1 --tf 3 --t-end 4 --verify --out OUT/three-link.csv"
  echo "solve $models/gantry_crane.yaml --trajectory rest-to-rest --y0 0,2 --yf 1,2 --t0 0 --tf 3 --t-end 4 --sample-time 0.01 --verify --out OUT/crane.csv"
  echo "solve $models/mass_spring_chain.yaml --trajectory rest-to-rest --y0 0 --yf 1 --t0 0 --tf 5 --t-end 6 --verify --out OUT/chain.csv"
  echo "solve $data/three_mass_chain_unstable_output.yaml --trajectory rest-to-rest --y0 0 --yf 1 --t0 0 --tf 4 --t-end 5 --verify --out OUT/tangential.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method radau,bdf --verify --summary text --out OUT/overlay.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method bdf,radau --out OUT/overlay-json.csv"
  echo "solve $models/rotational_arm.yaml --set s=1 --trajectory rest-to-rest --y0 0 --yf 270deg --t0 1 --tf 3 --t-end 4 --method stable-inversion --verify --summary text --out OUT/arm-text.csv"
  echo "solve $models/rotational_arm.yaml --set s=1 --trajectory rest-to-rest --y0 0 --yf 1 --t0 1 --tf 3 --t-end 4 --method normal-form --out OUT/refused.csv"
  echo "analyze $models/mass_on_car.yaml --set nope=1"
  echo "analyze GEN/chain/chain_300.yaml --which leftmost"
  echo "analyze GEN/chain/chain_300.yaml --eigenvalues 0"
  echo "analyze $models/mass_on_car.yaml --rank-tolerance 2"
  echo "threshold $models/mass_on_car.yaml --vary alpha=1deg:80deg --event oscillation --set d=1 --format text"
  echo "threshold $models/rotational_arm.yaml --vary s=0:1 --event stability --format text --no-closed-form"
  echo "threshold $models/rotational_arm.yaml --vary s=0:1 --event realization --scan 50 --tolerance 1e-9"
  echo "threshold $models/mass_on_car.yaml --vary alpha=0.1:1.5 --event oscillation --set d=1 --y0 0.1"
  echo "threshold $models/mass_on_car.yaml --vary k=1:10 --event stability --set alpha=30deg --set d=1"
  echo "threshold GEN/chain/chain_300.yaml --vary d=0:1 --event stability"
  echo "threshold $models/mass_on_car.yaml --vary nope=0:1 --event stability"
  echo "threshold $models/mass_on_car.yaml --vary alpha=0:1 --event weather"
  echo "threshold $models/mass_on_car.yaml --vary alpha=0:1 --event stability --scan 0"
  echo "generate chain --masses 0 --out OUT/no-chain"
  echo "generate chain --masses 5 --output-weights linear --output-mass 2 --out OUT/no-chain"
  echo "generate chain --masses 5 --output-weights heavy --out OUT/no-chain"
  echo "generate chain --masses 5 --name ../escape --out OUT/chain-name"
  echo "generate beam --elements 3 --length -1 --out OUT/no-beam"
  echo "generate beam --elements 3 --name link --out OUT/beam-name"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --method radau,bdf --verify --plot OUT/figures --out OUT/plotted.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --format mat --out OUT/u.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 $rest --out OUT/case2.mat"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 --trajectory $root/tests/fuzz/corpus/trajectory_file/dense.csv --sample-tolerance 2 --t-end 10 --out OUT/s.csv"
  echo "solve $models/mass_on_car.yaml --set alpha=5deg --set d=1 --trajectory $root/tests/fuzz/corpus/trajectory_file/dense.csv --t-end 10 --out OUT/s.csv"
  echo "solve $models/mass_on_car.yaml --trajectory $data/errors/samples_not_a_number.csv --t-end 10 --out OUT/s.csv"
  echo "report paper --out OUT/paper --models $models"
  echo "report $models/rotational_arm.yaml --vary s=0:1:n=11 --out OUT/arm-report"
  echo "report $models/mass_on_car.yaml --vary alpha=5deg:85deg:5 --vary d=0:2:3 --set k=4 --out OUT/map-report"
  echo "sweep $models/mass_on_car.yaml --vary alpha=0deg:90deg:7 --vary d=0:2:3 --block-size 5 --out GEN/from-sweep"
  echo "report --from GEN/from-sweep --out OUT/from-report"
  echo "sweep $models/mass_on_car.yaml --vary alpha=0deg:90deg:7 --vary d=0:2:3 --block-size 5 --out GEN/from-sweep"
  echo "sweep $models/mass_on_car.yaml --vary alpha=5deg,30deg --out GEN/from-sweep"
  echo "sweep $models/mass_on_car.yaml --vary alpha=0deg:90deg:step=15deg --format hdf5 --out OUT/h5"
  echo "sweep $models/mass_on_car.yaml --vary d=0:2:4 --format mat --out OUT/mat"
  echo "sweep $models/rotational_arm.yaml --vary s=0:1:n=5 --y0 0.1 --q0 0.1,0 --rank-tolerance 1e-8 --out OUT/point"
  echo "sweep GEN/chain/chain_300.yaml --vary d=0.01,0.1 --eigen-solver arpack --eigenvalues 4 --which rightmost --out OUT/chain-arpack"
  echo "sweep $models/mass_on_car.yaml --vary beta=0:1:3 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --vary d=2 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --set d=2 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --format xml --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --threads 0 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --block-size 0 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --checkpoint-interval 0 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --eigenvalues 4 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary d=0:1:3 --rank-tolerance 2 --out OUT/bad"
  echo "sweep GEN/chain/chain_300.yaml --vary d=0.01 --y0 1 --out OUT/bad"
  echo "sweep GEN/chain/chain_300.yaml --vary d=0.01 --eigenvalues 0 --out OUT/bad"
  echo "sweep $models/mass_on_car.yaml --vary alpha=0:7:3 --out OUT/warned"
  echo "report --from $data/report_from/incomplete --out OUT/bad"
  echo "report --from $data/report_from/linear --out OUT/bad"
  echo "report --from $data/report_from/hdf5 --out OUT/bad"
  echo "report --from $data/errors --out OUT/bad"
  echo "report $models/mass_on_car.yaml --vary beta=0:1:3 --out OUT/bad"
}

# Runs every command with one executable; stdout to $dir/NNN.stdout, status to NNN.status.
run_all() {
  local servokit=$1 side=$2
  mkdir -p "$work/run"
  local n=0
  while read -r line; do
    n=$((n + 1))
    local id
    id=$(printf '%03d' "$n")
    mkdir -p "$work/run/$id"
    # shellcheck disable=SC2086
    line=${line//GEN/$work/run/generated}
    eval "set -- ${line//OUT/$work/run/$id}"
    (cd "$work/run" && "$servokit" "$@" >"$work/run/$id.stdout" 2>"$work/run/$id.stderr"
     echo $? >"$work/run/$id.status")
  done < <(commands)
  mv "$work/run" "$work/$side"
}

run_all "$old" old
run_all "$new" new

status=0
n=0
while read -r line; do
  n=$((n + 1))
  id=$(printf '%03d' "$n")
  # The report's timings and the sweep's record of how long it ran are not results.
  if ! diff -r -q -x 'timing*' "$work/old/$id" "$work/new/$id" >/dev/null ||
     ! cmp -s "$work/old/$id.stdout" "$work/new/$id.stdout" ||
     ! cmp -s "$work/old/$id.stderr" "$work/new/$id.stderr" ||
     ! cmp -s "$work/old/$id.status" "$work/new/$id.status"; then
    echo "DIFFERS: servokit $line"
    diff -r "$work/old/$id" "$work/new/$id" | head -5
    diff "$work/old/$id.stdout" "$work/new/$id.stdout" | head -5
    diff "$work/old/$id.stderr" "$work/new/$id.stderr" | head -5
    status=1
  fi
  if [ "$(cat "$work/old/$id.status")" != 0 ]; then
    echo "note: exit $(cat "$work/old/$id.status") for servokit $line: $(head -c 300 "$work/old/$id.stderr")"
  fi
done < <(commands)
echo "$n commands compared: $([ $status = 0 ] && echo 'all byte-identical' || echo 'some differ')"
exit $status
