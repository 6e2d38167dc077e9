#!/usr/bin/env bash
# Side-by-side at equal accuracy: paper case 3 (alpha = 0, d = 1; tangential, relative degree 3)
# by servokit's auto (the input-output normal form derived from the model file, Dormand-Prince
# on its internal coordinate) and by SciPy's solve_ivp (RK45, DOP853) on the hand-written
# Eq. (40). Each side runs at several rtol; the error of u against the exact solution of
# Eq. (40) is measured at every row. For every servokit run the ratio is the time of the
# fastest SciPy run at least as accurate, over servokit's time (goal: >= 10).
#
# Usage: bench/compare_case3.sh [BUILD_DIR]     (default: build)
# Environment: PYTHON (default /usr/bin/python3, Debian's, with SciPy).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}

scipy=$("$python" "$root/bench/scipy_case3.py")
servokit=$("$build/bench/bench_solve" "$root/models" 10 case3 | "$python" "$root/bench/scipy_case3.py" --errors)
"$python" - "$scipy" "$servokit" <<'PY'
import json, sys
scipy = [json.loads(line) for line in sys.argv[1].splitlines()]
servokit = [json.loads(line) for line in sys.argv[2].splitlines()]
print(f"{'servokit rtol':>12s} {'steps':>6s} {'error':>9s} {'ms':>8s}   "
      f"{'fastest SciPy at least as accurate':36s} {'ms':>8s} {'x faster':>9s}")
for ours in servokit:
    peers = [p for p in scipy if p["error"] <= ours["error"]]
    line = (f"{ours['rtol']:12.0e} {ours['steps']:6d} {ours['error']:9.2e} "
            f"{1e3 * ours['seconds']:8.3f}   ")
    if not peers:
        print(line + "none reaches this accuracy")
        continue
    peer = min(peers, key=lambda p: p["seconds"])
    label = f"{peer['method']} rtol {peer['rtol']:.0e} ({peer['steps']} steps, {peer['error']:.1e})"
    print(line + f"{label:36s} {1e3 * peer['seconds']:8.3f} {peer['seconds'] / ours['seconds']:9.1f}")
PY
