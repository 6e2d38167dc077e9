#!/usr/bin/env bash
# Side-by-side: stable inversion of the rotational arm (paper Sect. 5.3, output at s = l, 0 to
# 270 deg in 1-3 s) by servokit (SolveStableInversion: bvp4c-style collocation on the normal form
# derived from the model file, one solve without widening) and by SciPy's solve_bvp on the
# hand-written internal dynamics, same boundary value problem, same window (servokit's, passed
# on) and same tolerance (1e-6). Both report their best time of several runs of the solve alone;
# T at 0.9 s (pre-actuation) and 2.0 s is interpolated linearly on each solver's own mesh.
#
# Usage: bench/compare_stable_inversion.sh [BUILD_DIR]     (default: build)
# Environment: PYTHON (default /usr/bin/python3, Debian's, with SciPy).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-/usr/bin/python3}
tolerance=1e-6

servokit=$("$build/bench/bench_stable_inversion" "$root/models" "$tolerance" 5)
window=$("$python" -c 'import json, sys; r = json.loads(sys.argv[1]); print(repr(r["window_start"]), repr(r["window_end"]))' "$servokit")
read -r window_start window_end <<<"$window"
scipy=$("$python" "$root/bench/scipy_stable_inversion.py" --tolerance "$tolerance" --repetitions 5 \
        "--window-start=$window_start" "--window-end=$window_end")
"$python" - "$scipy" "$servokit" <<'PY'
import json, sys
scipy, ours = json.loads(sys.argv[1]), json.loads(sys.argv[2])
print(f"window [{ours['window_start']:.6f}, {ours['window_end']:.6f}] s, tolerance {ours['tolerance']:g}")
print(f"{'solve':28s} {'mesh':>6s} {'ms':>9s} {'x SciPy':>8s} {'max |T|':>10s} {'T(0.9)':>12s} {'T(2.0)':>12s}")
for name, r in (("SciPy solve_bvp", scipy), ("servokit stable inversion", ours)):
    print(f"{name:28s} {r['mesh_points']:6d} {1e3 * r['seconds']:9.3f} "
          f"{scipy['seconds'] / r['seconds']:8.2f} {r['max_abs_T']:10.4f} "
          f"{r['T_0_9']:12.6f} {r['T_2_0']:12.6f}")
difference = max(abs(ours["T_0_9"] - scipy["T_0_9"]), abs(ours["T_2_0"] - scipy["T_2_0"]))
print(f"accuracy check: max |T_servokit - T_SciPy| at 0.9 s and 2.0 s = {difference:.2e} N m")
PY
