#!/usr/bin/env bash
# Side-by-side: the 10 zero-dynamics eigenvalues nearest 0 of large linear models (issue #6),
# servokit (bench/large_model_bench.cpp: solves with R(0) = [[-K, B], [C, 0]] through the Schur
# complement on an LDLT of K, or the SparseLU of R(0) when K is singular (the beam's free hub),
# ARPACK shift-invert on (q, v)) against SciPy (bench/scipy_large_eigs.py: eigs(A, k, M=E, sigma=0) on
# the (2n + m) Rosenbrock pencil, SuperLU + ARPACK), on the same files written by
# `servokit generate chain|beam`.
#
# Dense-output mode (issue #19): OUTPUT_WEIGHTS=linear (or uniform) generates each chain with
# `--output-weights linear`, y = sum (i/N) q_i, a dense row of C, and compares against the SciPy
# bordered peer bench/scipy_bordered_eigs.py (SuperLU of K + sigma D + sigma^2 M only, the border
# through the Schur complement, eigs on a LinearOperator) instead of the pencil peer, whose LU of
# the bordered matrix fills in. Only the chain has the option: MODELS defaults to "chain" there.
#
# Usage: bench/compare_large.sh [BUILD_DIR]      (default: build)
# Environment: SIZES (default "1000 10000 100000"; add 1000000 for the chain if memory allows),
#              MODELS (default "chain beam"), K (default 10), NCV (ARPACK basis size for both
#              tools, default servokit's max(2K + 10, 30)),
#              PYTHON (default /usr/bin/python3, Debian's, with SciPy and PyYAML),
#              OUTPUT_WEIGHTS (default mass: the output at mass 1; linear or uniform: see above),
#              REPEAT (default 1: runs per tool and size, alternating; each column shows the
#              best run, which is what a shared, busy machine can measure).
# Times are each tool's own phase timers (assembling the matrices and the pencil + LU +
# eigensolver; reading the files and process start-up excluded on both sides); peak memory is
# each process's max RSS (getrusage), which includes reading the files and, for SciPy, the
# interpreter and NumPy (~60 MB). ratio = SciPy seconds / servokit seconds (> 1: servokit
# faster); mem = SciPy MB / servokit MB (> 1: servokit smaller); cpu = the two processes' user +
# system CPU seconds (/usr/bin/time, start-up and reading the files included). The largest
# relative difference between the two eigenvalue lists is printed too.
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
sizes=${SIZES:-"1000 10000 100000"}
weights=${OUTPUT_WEIGHTS:-mass}
if [[ $weights == mass ]]; then
  models=${MODELS:-"chain beam"}
  peer="$root/bench/scipy_large_eigs.py"
else
  models=${MODELS:-chain}
  peer="$root/bench/scipy_bordered_eigs.py"
fi
k=${K:-10}
repeat=${REPEAT:-1}
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

cpu() {  # cpu FILE: the least user + system seconds of the runs /usr/bin/time -a appended
  "$python" - "$1" <<'EOF'
import sys
words = open(sys.argv[1]).read().split()
print("%.2f" % min(float(u) + float(s) for u, s in zip(words[::2], words[1::2])))
EOF
}

best() {  # best JSON_A JSON_B: the run with the smaller "seconds" (JSON_A may be empty)
  "$python" - "$1" "$2" <<'EOF'
import json, sys
runs = [text for text in sys.argv[1:] if text]
print(min(runs, key=lambda text: json.loads(text)["seconds"]))
EOF
}

printf "%-6s %8s | %10s %10s %8s | %10s %10s %8s | %7s %7s | %s\n" model N servokit_s rss_MB cpu_s \
  scipy_s rss_MB cpu_s ratio mem max_rel_diff
for model in $models; do
  for n in $sizes; do
    dir="$work/$model-$n"
    mkdir -p "$dir"
    if [[ $model == chain ]]; then
      "$servokit" generate chain --masses "$n" --output-weights "$weights" --out "$dir" >/dev/null
    else
      "$servokit" generate beam --elements "$n" --out "$dir" >/dev/null
    fi
    yaml=$(ls "$dir"/*.yaml)
    # servokit refuses a model whose zeros would carry no correct digit (the beam from 1e4
    # elements on, issue #19): say so in the table and go on.
    if ! "$bench" "$yaml" "$k" "$ncv" >/dev/null 2>"$dir/error"; then
      printf "%-6s %8s | refused: %s\n" "$model" "$n" "$(cut -c1-100 "$dir/error")"
      rm -rf "$dir"
      continue
    fi
    ours="" theirs=""
    for ((run = 0; run < repeat; ++run)); do  # alternating, so that both see the same load
      ours=$(best "$ours" "$(/usr/bin/time -f "%U %S" -a -o "$work/ours.time" "$bench" "$yaml" \
        "$k" "$ncv")")
      theirs=$(best "$theirs" "$(/usr/bin/time -f "%U %S" -a -o "$work/theirs.time" "$python" \
        "$peer" "$yaml" "$k" "$ncv")")
    done
    ours_s=$(field "$ours" seconds)
    theirs_s=$(field "$theirs" seconds)
    ours_mb=$(field "$ours" max_rss_mb)
    theirs_mb=$(field "$theirs" max_rss_mb)
    ratio=$("$python" -c "print('%.2f' % ($theirs_s / $ours_s))")
    mem=$("$python" -c "print('%.2f' % ($theirs_mb / $ours_mb))")
    printf "%-6s %8s | %10.3f %10.1f %8s | %10.3f %10.1f %8s | %7s %7s | %s\n" "$model" "$n" \
      "$ours_s" "$ours_mb" "$(cpu "$work/ours.time")" "$theirs_s" "$theirs_mb" \
      "$(cpu "$work/theirs.time")" "$ratio" "$mem" "$(difference "$ours" "$theirs")"
    rm -rf "$dir" "$work/ours.time" "$work/theirs.time"
  done
done
