#!/usr/bin/env bash
# Side-by-side (issue #29): the same motion given in closed form and as samples. The mass on
# car (alpha = 5 deg, d = 1) moves its output from 0.5 to 2.5 by Eq. (65) over [0, 6] s;
# `servokit solve` computes u_d up to t = 10 s from `--trajectory rest-to-rest` and from a CSV
# file of N samples of the same motion, joined two ways: by the default fit (a spline within
# 1e-10 of the range of the samples on as few knots as that allows; Eq. 65 lies in every such
# space, so it takes none inside) and by the interpolating spline (--sample-tolerance 0), which
# carries the samples' rounding (Python's Eq. 65, 1e-13) into the derivatives of y_d, the m-th
# multiplied by some (c/h)^m. Each evaluation of either spline is a binary search and de Boor's
# recurrence, linear in N overall (GSL 2.7's knot search from the first knot made it quadratic:
# 10^5 samples took 11.9 s here).
#
# Radau IIA at its default tolerances throughout (BDF, auto's choice, stops on the interpolated
# 10^5 samples: its error test reads y_d'' through the residual and cannot pass on that noise).
# Each time is the least of REPEAT runs of the whole command, reading the file included; steps
# are Radau's accepted steps; the difference is the largest |F| difference from the closed form
# on the grid --sample-time 0.01 (F is some 1 N; Radau's own error in F at rtol 1e-8 is some
# 4e-5 N, the closed form's against itself at rtol 1e-11).
#
# Usage: bench/compare_sampled_trajectory.sh [BUILD_DIR]     (default: build)
# Environment: REPEAT (default 3), SAMPLES (default "10000 100000"), PYTHON (default python3).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" && pwd)/application/servokit"
python=${PYTHON:-python3}
repeat=${REPEAT:-3}
samples=${SAMPLES:-"10000 100000"}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$python" - "$servokit" "$root/models/mass_on_car.yaml" "$work" "$repeat" $samples <<'PY'
import csv, json, subprocess, sys, time

servokit, model, work, repeat = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
counts = [int(n) for n in sys.argv[5:]]
t0, tf, y0, yf, t_end = 0.0, 6.0, 0.5, 2.5, 10.0
common = ["--t-end", str(t_end), "--method", "radau", "--sample-time", "0.01"]


def eq65(t):  # the paper's Eq. (65), y0 to yf over [t0, tf]
    tau = (t - t0) / (tf - t0)
    return y0 + (yf - y0) * tau**5 * (126 - 420 * tau + 540 * tau**2 - 315 * tau**3 + 70 * tau**4)


def solve(trajectory, out):
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        summary = subprocess.run([servokit, "solve", model, *trajectory, *common, "--out", out],
                                 check=True, capture_output=True, text=True).stdout
        best = min(best, time.perf_counter() - start)
    with open(out) as file:
        rows = list(csv.DictReader(file))
    return best, json.loads(summary)["steps"], [float(row["F"]) for row in rows]


closed_time, closed_steps, closed_force = solve(
    ["--trajectory", "rest-to-rest", "--y0", str(y0), "--yf", str(yf), "--t0", str(t0), "--tf",
     str(tf)], f"{work}/closed.csv")
print(f"{'trajectory':34s} {'seconds':>9s} {'x closed form':>14s} {'us per sample':>14s} "
      f"{'steps':>6s} {'max |dF| [N]':>13s}")
print(f"{'rest-to-rest (closed form)':34s} {closed_time:9.3f} {1.0:14.1f} {'':>14s} "
      f"{closed_steps:6d} {'':>13s}")
for count in counts:
    path = f"{work}/samples-{count}.csv"
    with open(path, "w") as file:
        file.write("t,y\n")
        for i in range(count):
            t = t0 + (tf - t0) * i / (count - 1)
            file.write(f"{t!r},{eq65(t)!r}\n")
    for label, tolerance in (("fitted", []), ("interpolated", ["--sample-tolerance", "0"])):
        seconds, steps, force = solve(["--trajectory", path, *tolerance],
                                      f"{work}/samples-{count}-u.csv")
        difference = max(abs(a - b) for a, b in zip(force, closed_force))
        print(f"{f'{count} samples, {label}':34s} {seconds:9.3f} {seconds / closed_time:14.1f} "
              f"{1e6 * (seconds - closed_time) / count:14.2f} {steps:6d} {difference:13.2e}")
PY
