#!/usr/bin/env bash
# Model size (issue #31): the symbolic core (GiNaC's derivatives at load, the symbolic nonlinear
# structure of `analyze`) on models of realistic size, against the issue's targets. The models
# come from bench/size_models.py (products of sums, long sums, chains of pendulums as energies,
# planar arms as bodies, a five-bar linkage through atan2 and sqrt, the index-5 arm with an
# elastic joint); the shipped models are rows
# too, for the target that every shipped-size model loads and analyses in 10 ms.
#
# Per model, three columns, each CPU seconds (user + system) and peak memory (max RSS, MB):
#   analyze  `servokit analyze FILE --format json`: loading and the whole analysis;
#   sweep    `servokit sweep FILE --vary P=V --threads 1` over the file's own value of its first
#            parameter: one point, and a sweep skips the symbolic nonlinear structure, so this is
#            loading (GiNaC's derivatives and the compiled programs) with one numeric point;
#   sympy    the pipeline a SymPy user would write (size_models.py --peer: parse the same
#            expressions, Lagrange's equations where the file gives energies, the Jacobian of f
#            with sympy.diff, lambdify, one evaluation); "-" where SymPy is missing or for the
#            shipped models, which the peer does not rebuild.
# A run that reaches LIMIT seconds (wall clock) prints "timed out" (the symptom of issue #31), one
# that fails prints its exit status. Each run is timed by /usr/bin/time (10 ms resolution, peak
# memory); one under 0.5 s is timed again as the mean of REPEAT runs from bash's `times`
# (1 ms resolution over all the runs). Not bench/child_cpu.py: it has no time limit and runs every command twice,
# which a 60 s limit cannot afford, and a sweep run again into its finished directory does
# nothing, so each run needs its own --out.
#
# Usage: bench/compare_model_size.sh [BUILD_DIR]      (default: build)
# Environment: LIMIT (seconds per run, default 60), REPEAT (default 10), PYTHON (default
#              /usr/bin/python3, Debian's, with python3-sympy for the peer), CASES (a regular
#              expression on the model names, default all; "threshold" selects the thresholds).
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
python=${PYTHON:-/usr/bin/python3}
limit=${LIMIT:-60}
repeat=${REPEAT:-10}
cases=${CASES:-.}
generator="$root/bench/size_models.py"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mapfile -t generated < <("$python" "$generator" "$work/models")
sympy=no
"$python" -c 'import sympy, numpy' 2>/dev/null && sympy=yes

# The issue's target for a row (the issue names these sizes; other rows have none).
target() {
  case $1 in
    models/*) echo "<= 10 ms" ;;
    product_of_sums_10) echo "< 0.1 s to load" ;;
    sum_of_terms_100000) echo "< 1 s" ;;
    pendulum_chain_400) echo "< 5 s and 1 GB" ;;
    planar_arm_50) echo "< 2 s" ;;
    five_bar) echo "< 1 s" ;;
    elastic_joint_arm) echo "< 0.05 s" ;;
    *) echo "-" ;;
  esac
}

# command_of KIND FILE NAME OUT: the command of column KIND, in the array cmd.
command_of() {
  case $1 in
    analyze) cmd=("$servokit" analyze "$2" --format json) ;;
    sweep) cmd=("$servokit" sweep "$2" --vary "$vary" --threads 1 --out "$4") ;;
    sympy) cmd=("$python" "$generator" --peer "$3") ;;
    threshold) cmd=("$servokit" threshold "$2" --vary "$threshold_vary" --event stability) ;;
  esac
}

# measure KIND FILE NAME: sets cpu and mb ("timed out" or "exit N" and "-" when it did not finish).
measure() {
  local status=0 i
  command_of "$1" "$2" "$3" "$work/out/first"
  /usr/bin/time -f "%U %S %M" -o "$work/time" timeout "$limit" "${cmd[@]}" >/dev/null \
    2>"$work/stderr" || status=$?
  rm -rf "$work/out"
  mb=-
  if ((status == 124)); then cpu="timed out"; return; fi
  if ((status != 0)); then cpu="exit $status"; return; fi
  read -r cpu mb < <(tail -1 "$work/time" | awk '{ printf "%.2f %.0f\n", $1 + $2, $3 / 1024 }')
  if awk -v c="$cpu" 'BEGIN { exit !(c < 0.5) }'; then
    # bash's `times` prints the subshell's children's user and system time as 0m0.123456s.
    cpu=$( (for ((i = 0; i < repeat; i++)); do
      command_of "$1" "$2" "$3" "$work/out/$i"
      "${cmd[@]}" >/dev/null 2>&1
    done; times) | tail -1 | awk -v n="$repeat" '{
      split($1, u, /[ms]/); split($2, s, /[ms]/)
      printf "%.4f", (60 * (u[1] + s[1]) + u[2] + s[2]) / n }')
    rm -rf "$work/out"
  fi
}

row() {  # row NAME FILE
  local a_cpu a_mb s_cpu s_mb p_cpu=- p_mb=-
  vary=$("$python" "$generator" --first-parameter "$2")  # the sweep's one point: P=V as filed
  measure analyze "$2" "$1"; a_cpu=$cpu a_mb=$mb
  measure sweep "$2" "$1"; s_cpu=$cpu s_mb=$mb
  if [[ $sympy == yes && $1 != models/* ]]; then measure sympy "$2" "$1"; p_cpu=$cpu p_mb=$mb; fi
  printf "%-26s %10s %6s | %10s %6s | %10s %6s | %s\n" "$1" "$a_cpu" "$a_mb" "$s_cpu" "$s_mb" \
    "$p_cpu" "$p_mb" "$(target "$1")"
}

echo "limit ${limit} s per run (wall clock); CPU seconds, peak MB; sympy: $sympy"
echo "servokit: $servokit; load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf "%-26s %10s %6s | %10s %6s | %10s %6s | %s\n" model analyze_s MB sweep_s MB sympy_s MB target
for model in "$root"/models/*.yaml; do
  name="models/$(basename "$model" .yaml)"
  if [[ $name =~ $cases ]]; then row "$name" "$model"; fi
done
for model in "${generated[@]}"; do
  name=$(basename "$model" .yaml)
  if [[ $name =~ $cases ]]; then row "$name" "$model"; fi
done
# The target "threshold over a parameter inside transcendental functions: as fast as over a
# plain coefficient": the flexible link's output point xi sits in cosh, cos, sinh and sin of its
# three mode shapes (its closed form is past the budget, so the numeric route runs; it used to
# run past 14 minutes in GiNaC's resultant), its hub inertia Jh and stiffness EI are plain
# coefficients; the arm's output point s sits inside atan2 in rotational_arm_tip and is a plain
# coefficient in rotational_arm.
threshold_row() {  # threshold_row LABEL FILE VARY
  threshold_vary=$3
  measure threshold "$2" "$1"
  printf "%-40s %10s %6s\n" "$1" "$cpu" "$mb"
}
if [[ threshold =~ $cases ]]; then
  printf "%-40s %10s %6s\n" "threshold --event stability" cpu_s MB
  link="$root/tests/data/flexible_link_modes.yaml"
  threshold_row "flexible link, xi (cosh, sin)" "$link" xi=0.1:1
  threshold_row "flexible link, Jh (plain)" "$link" Jh=0.05:5
  threshold_row "flexible link, EI (plain)" "$link" EI=0.5:5
  threshold_row "rotational_arm_tip, s (atan2)" "$root/models/rotational_arm_tip.yaml" s=0:1
  threshold_row "rotational_arm, s (plain)" "$root/models/rotational_arm.yaml" s=0:1
fi
echo "load average at the end $(cut -d' ' -f1-3 /proc/loadavg)"
