#!/usr/bin/env bash
# Side-by-side: the 10 zero-dynamics eigenvalues nearest 0 of large linear models (issue #6),
# servokit (bench/large_model_bench.cpp: R(0) = [[-K, B], [C, 0]], Eigen SparseLU, ARPACK
# shift-invert on (q, v)) against SciPy (bench/scipy_large_eigs.py: eigs(A, k, M=E, sigma=0) on
# the (2n + m) Rosenbrock pencil, SuperLU + ARPACK), on the same files written by
# `servokit generate chain|beam`.
#
# Usage: bench/compare_large.sh [BUILD_DIR]      (default: build)
# Environment: SIZES (default "1000 10000 100000"; add 1000000 for the chain if memory allows),
#              MODELS (default "chain beam"), K (default 10), NCV (ARPACK basis size for both
#              tools, default servokit's max(2K + 10, 30)),
#              PYTHON (default /usr/bin/python3, Debian's, with SciPy and PyYAML).
# Times are each tool's own phase timers (assembling the matrices and the pencil + LU +
# eigensolver; reading the files and process start-up excluded on both sides); peak memory is
# each process's max RSS (getrusage), which includes reading the files and, for SciPy, the
# interpreter and NumPy (~60 MB). ratio = SciPy seconds / servokit seconds (> 1: servokit
# faster). The largest relative difference between the two eigenvalue lists is printed too.
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
sizes=${SIZES:-"1000 10000 100000"}
models=${MODELS:-"chain beam"}
k=${K:-10}
ncv=${NCV:-$(( 2 * k + 10 > 30 ? 2 * k + 10 : 30 ))}
servokit="$build/application/servokit"
bench="$build/bench/bench_large_model"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

field() {  # field JSON NAME
  "$python" -c 'import json, sys; print(json.loads(sys.argv[1])[sys.argv[2]])' "$1" "$2"
}

difference() {  # difference JSON_A JSON_B: largest |a - b| / max(1, |a|) over sorted lists
  "$python" - "$1" "$2" <<'EOF'
import json, sys
a = [complex(*z) for z in json.loads(sys.argv[1])["eigenvalues"]]
b = [complex(*z) for z in json.loads(sys.argv[2])["eigenvalues"]]
if len(a) != len(b):
    print("count %d vs %d" % (len(a), len(b)))
else:
    used, worst = set(), 0.0
    for x in a:
        j = min((j for j in range(len(b)) if j not in used), key=lambda j: abs(x - b[j]))
        used.add(j)
        worst = max(worst, abs(x - b[j]) / max(1.0, abs(x)))
    print("%.1e" % worst)
EOF
}

printf "%-6s %8s | %10s %10s | %10s %10s | %7s | %s\n" model N servokit_s rss_MB scipy_s \
  rss_MB ratio max_rel_diff
for model in $models; do
  for n in $sizes; do
    dir="$work/$model-$n"
    mkdir -p "$dir"
    if [[ $model == chain ]]; then
      "$servokit" generate chain --masses "$n" --out "$dir" >/dev/null
    else
      "$servokit" generate beam --elements "$n" --out "$dir" >/dev/null
    fi
    yaml=$(ls "$dir"/*.yaml)
    # servokit refuses a model whose zeros would carry no correct digit (the beam from 1e4
    # elements on, issue #19): say so in the table and go on.
    if ! ours=$("$bench" "$yaml" "$k" "$ncv" 2>"$dir/error"); then
      printf "%-6s %8s | refused: %s\n" "$model" "$n" "$(cut -c1-100 "$dir/error")"
      rm -rf "$dir"
      continue
    fi
    theirs=$("$python" "$root/bench/scipy_large_eigs.py" "$yaml" "$k" "$ncv")
    ours_s=$(field "$ours" seconds)
    theirs_s=$(field "$theirs" seconds)
    ratio=$("$python" -c "print('%.2f' % ($theirs_s / $ours_s))")
    printf "%-6s %8s | %10.3f %10.1f | %10.3f %10.1f | %7s | %s\n" "$model" "$n" "$ours_s" \
      "$(field "$ours" max_rss_mb)" "$theirs_s" "$(field "$theirs" max_rss_mb)" "$ratio" \
      "$(difference "$ours" "$theirs")"
    rm -rf "$dir"
  done
done
