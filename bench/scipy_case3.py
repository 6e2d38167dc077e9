#!/usr/bin/env python3
"""The SciPy peer of bench_solve case3: the mass on car, case 3 (alpha = 0, d = 1: tangential,
relative degree 3, paper Sect. 3), written by hand as a SciPy user would: the internal dynamics
Eq. (40), k s + d s' = -m2 y_d'', integrated with solve_ivp (RK45 and DOP853) over [0, 6] and
[6, 10] (y_d is not smooth at tf = 6), and the force from Eqs. (39), (41), (42) at every step:
    F = -(m1 + m2)/m2 (k s + d s') - m1 s'',   s' = (g - k s)/d,   s'' = (g' - k s')/d,
g = -m2 y_d''. Same trajectory as servokit (Eq. 65: 0.5 m to 2.5 m in 0-6 s).

Also the accuracy reference for both sides: Eq. (40) solved exactly (a polynomial particular
solution plus the decaying exponential, as tests/solvers/inverse_model_test.cpp).

Usage: scipy_case3.py [--repetitions N]           prints one JSON object per (method, rtol)
       scipy_case3.py --errors < servokit.jsonl   adds "error" (max |u - exact| / max |exact|)
"""
import argparse
import json
import math
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

M1, M2, K, D = 1.0, 2.0, 5.0, 1.0
Y0, YF, T0, TF, TEND = 0.5, 2.5, 0.0, 6.0, 10.0
# Eq. (65): p(tau) = 126 tau^5 - 420 tau^6 + 540 tau^7 - 315 tau^8 + 70 tau^9.
P = np.polynomial.Polynomial([0, 0, 0, 0, 0, 126, -420, 540, -315, 70])


def y_derivative(t, order):
    if t <= T0 or t >= TF:
        return 0.0 if order > 0 else (Y0 if t <= T0 else YF)
    return (YF - Y0) * P.deriv(order)((t - T0) / (TF - T0)) / (TF - T0) ** order if order else \
        Y0 + (YF - Y0) * P((t - T0) / (TF - T0))


def g(t, order=0):
    return -M2 * y_derivative(t, order + 2)


def force(t, s):
    s_dot = (g(t) - K * s) / D
    s_ddot = (g(t, 1) - K * s_dot) / D
    return -(M1 + M2) / M2 * (K * s + D * s_dot) - M1 * s_ddot


def polynomial_g(t, order):
    """g^(order) of the motion's polynomial at t in [t0, tf], ends included (from inside)."""
    tau = min(max((t - T0) / (TF - T0), 0.0), 1.0)
    return -M2 * (YF - Y0) * P.deriv(order + 2)(tau) / (TF - T0) ** (order + 2)


def exact_s(t):
    def particular(time):
        return sum((-D / K) ** j * polynomial_g(time, j) for j in range(10)) / K
    rate = K / D
    constant = -particular(T0)
    if t <= TF:
        return particular(t) + constant * math.exp(-rate * t)
    return (particular(TF) + constant * math.exp(-rate * TF)) * math.exp(-rate * (t - TF))


def relative_error(times, forces):
    exact = [force(t, exact_s(t)) for t in times]
    scale = max(abs(value) for value in exact)
    return max(abs(a - b) for a, b in zip(forces, exact)) / scale


def solve(method, rtol):
    times, forces, steps = [], [], 0
    state = [0.0]
    for start, end in ((T0, TF), (TF, TEND)):
        result = solve_ivp(lambda t, s: [(g(t) - K * s[0]) / D], (start, end), state,
                           method=method, rtol=rtol, atol=rtol * 1e-2)
        steps += len(result.t) - 1
        state = [result.y[0, -1]]
        for t, s in zip(result.t, result.y[0]):
            times.append(t)
            forces.append(force(t, s))
    return steps, times, forces


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repetitions", type=int, default=3)
    parser.add_argument("--errors", action="store_true")
    arguments = parser.parse_args()
    if arguments.errors:
        for line in sys.stdin:
            run = json.loads(line)
            run["error"] = relative_error(run.pop("t"), run.pop("u"))
            print(json.dumps(run))
        return
    for method in ("RK45", "DOP853"):
        for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
            best = math.inf
            for _ in range(arguments.repetitions):
                start = time.perf_counter()
                steps, times, forces = solve(method, rtol)
                best = min(best, time.perf_counter() - start)
            print(json.dumps({"method": "scipy-" + method, "rtol": rtol, "seconds": best,
                              "steps": steps, "error": relative_error(times, forces)}))


if __name__ == "__main__":
    main()
