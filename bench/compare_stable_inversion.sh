#!/usr/bin/env bash
# Side-by-side: stable inversion of the rotational arm (paper Sect. 5.3, output at s = l, 0 to
# 270 deg in 1-3 s) by servokit (SolveStableInversion: 7-point Lobatto collocation on the
# normal form derived from the model file) and by SciPy's solve_bvp (bvp4c's method) on the
# hand-written internal dynamics: the same boundary value problem on the same window, the
# one servokit chooses at its default tolerance 1e-8. Each reports its best time of several
# runs of the solve alone.
#
# Accuracy is measured, not assumed equal from the tolerance (the two solvers define their
# error tests differently): each solver evaluates T on 401 times in [0, 4] s with its own
# interpolant, and the error is the largest difference from a reference, servokit at
# tolerance 1e-10, itself checked against SciPy at 1e-9 (a second method). Rows:
#   same tolerance   both at 1e-6 and at 1e-8;
#   equal accuracy   for each SciPy run, servokit at the loosest tolerance in 1e-4 .. 1e-10
#                    whose error is not larger than SciPy's.
#
# Usage: bench/compare_stable_inversion.sh [BUILD_DIR]     (default: build)
# Environment: PYTHON (default /usr/bin/python3, Debian's, with SciPy).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
bench="$build/bench/bench_stable_inversion"

default_run=$("$bench" "$root/models" 1e-8 1)
window=$("$python" -c 'import json, sys; r = json.loads(sys.argv[1]); print(repr(r["window_start"]), repr(r["window_end"]))' "$default_run")
read -r window_start window_end <<<"$window"
results=$(mktemp -d)
trap 'rm -rf "$results"' EXIT
"$bench" "$root/models" 1e-10 1 "$window_start" "$window_end" >"$results/reference.json"
"$python" "$root/bench/scipy_stable_inversion.py" --tolerance 1e-9 --repetitions 1 \
  "--window-start=$window_start" "--window-end=$window_end" >"$results/scipy-1e-9.json"
for tolerance in 1e-6 1e-8; do
  "$python" "$root/bench/scipy_stable_inversion.py" --tolerance "$tolerance" --repetitions 10 \
    "--window-start=$window_start" "--window-end=$window_end" >"$results/scipy-$tolerance.json"
done
for tolerance in 1e-4 1e-5 1e-6 1e-7 1e-8 1e-9 1e-10; do
  "$bench" "$root/models" "$tolerance" 20 "$window_start" "$window_end" >"$results/servokit-$tolerance.json"
done
"$python" - "$results" <<'PY'
import json, os, sys
directory = sys.argv[1]
def load(name):
    with open(os.path.join(directory, name + ".json")) as file:
        return json.load(file)
reference = load("reference")["T_grid"]
def error(run):
    return max(abs(a - b) for a, b in zip(run["T_grid"], reference))
ours = {t: load(f"servokit-{t}") for t in ("1e-4", "1e-5", "1e-6", "1e-7", "1e-8", "1e-9", "1e-10")}
print(f"window [{ours['1e-8']['window_start']:.6f}, {ours['1e-8']['window_end']:.6f}] s; reference: "
      f"servokit at 1e-10 ({load('reference')['mesh_points']} points), differs from SciPy at 1e-9 "
      f"by {error(load('scipy-1e-9')):.1e} N m")
print(f"{'comparison':16s} {'SciPy tol':>9s} {'mesh':>5s} {'ms':>8s} {'T error':>9s} | "
      f"{'servokit tol':>12s} {'mesh':>5s} {'ms':>7s} {'T error':>9s} | {'x SciPy':>7s}")
for t in ("1e-6", "1e-8"):
    scipy = load(f"scipy-{t}")
    same = ours[t]
    equal = next((ours[s] for s in ours if error(ours[s]) <= error(scipy)), None)
    for label, run, tol in (("same tolerance", same, t), ("equal accuracy", equal, None)):
        if run is None:
            print(f"{label:16s} {t:>9s}: no servokit tolerance reached SciPy's error")
            continue
        tol = tol or next(s for s in ours if ours[s] is run)
        print(f"{label:16s} {t:>9s} {scipy['mesh_points']:5d} {1e3 * scipy['seconds']:8.2f} "
              f"{error(scipy):9.2e} | {tol:>12s} {run['mesh_points']:5d} {1e3 * run['seconds']:7.3f} "
              f"{error(run):9.2e} | {scipy['seconds'] / run['seconds']:7.1f}")
PY
