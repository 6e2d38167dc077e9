#!/usr/bin/env bash
# Side-by-side: the normal-form solve of the mass on car, case 2 (alpha = 5 deg, d = 1 and 0),
# by servokit (ARKODE Dormand-Prince on the normal form derived from the model file) and by
# SciPy's solve_ivp(RK45) on the hand-written Eqs. (35)-(36), same tolerances; and Radau IIA on
# case 4 (goal: under 1 ms). Both report their best time of several runs of the solve alone.
#
# Usage: bench/compare_solve.sh [BUILD_DIR]     (default: build)
# Environment: PYTHON (default /usr/bin/python3, Debian's, with SciPy).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}

scipy=$("$python" "$root/bench/scipy_solve.py")
servokit=$("$build/bench/bench_solve" "$root/models" 20)
"$python" - "$scipy" "$servokit" <<'PY'
import json, sys
scipy = [json.loads(line) for line in sys.argv[1].splitlines()]
servokit = [json.loads(line) for line in sys.argv[2].splitlines()]
print(f"{'solve':40s} {'steps':>7s} {'ms':>10s} {'x SciPy':>9s} {'s(10) difference':>17s}")
for peer in scipy:
    ours = next(r for r in servokit if r["method"] == "normal-form" and float(r["d"]) == peer["d"])
    print(f"{'case 2, d = %g: SciPy solve_ivp RK45' % peer['d']:40s} {peer['steps']:7d} "
          f"{1e3 * peer['seconds']:10.3f} {1.0:9.1f}")
    print(f"{'case 2, d = %g: servokit normal form' % peer['d']:40s} {ours['steps']:7d} "
          f"{1e3 * ours['seconds']:10.3f} {peer['seconds'] / ours['seconds']:9.1f} "
          f"{abs(ours['s_end'] - peer['s_end']):17.2e}")
radau = next(r for r in servokit if r["method"] == "radau")
print(f"{'case 4: servokit Radau IIA':40s} {radau['steps']:7d} {1e3 * radau['seconds']:10.3f}"
      f"   (goal: under 1 ms)")
PY
