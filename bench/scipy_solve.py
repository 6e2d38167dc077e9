#!/usr/bin/env python3
"""The SciPy peer of bench_solve: the normal form of the mass on car, case 2 (paper Sect. 5.2),
written by hand as a MATLAB/SciPy user would: internal dynamics Eq. (36),
    m2 sin^2(a) s'' + d s' + k s = -y_d'' m2 cos(a),
integrated with solve_ivp(RK45) (Dormand-Prince 5(4), like ode45) over [0, 6] and [6, 10]
(y_d'' is not smooth at tf = 6), and the input from Eq. (35) at every step. Same tolerances as
servokit (rtol 1e-10, atol 1e-12), same trajectory (Eq. 65: 0.5 m to 2.5 m in 0-6 s).
Prints one JSON object per damping value: best time of several runs, steps, s and F at t = 10.
"""
import argparse
import json
import math
import time

import numpy as np
from scipy.integrate import solve_ivp

M1, M2, K = 1.0, 2.0, 5.0
ALPHA = math.radians(5.0)
Y0, YF, T0, TF, TEND = 0.5, 2.5, 0.0, 6.0, 10.0
# Eq. (65): p(tau) = 126 tau^5 - 420 tau^6 + 540 tau^7 - 315 tau^8 + 70 tau^9.
P = np.polynomial.Polynomial([0, 0, 0, 0, 0, 126, -420, 540, -315, 70])
P2 = P.deriv(2)


def y_ddot(t):
    if t <= T0 or t >= TF:
        return 0.0
    return (YF - Y0) * P2((t - T0) / (TF - T0)) / (TF - T0) ** 2


def solve(d):
    sin2 = math.sin(ALPHA) ** 2
    cos = math.cos(ALPHA)

    def rhs(t, state):
        s, s_dot = state
        return [s_dot, (-d * s_dot - K * s - y_ddot(t) * M2 * cos) / (M2 * sin2)]

    steps = 0
    state = [0.0, 0.0]
    forces = []
    for start, end in ((T0, TF), (TF, TEND)):
        result = solve_ivp(rhs, (start, end), state, method="RK45", rtol=1e-10, atol=1e-12)
        steps += len(result.t) - 1
        state = result.y[:, -1]
        for t, s, s_dot in zip(result.t, result.y[0], result.y[1]):  # Eq. (35)
            forces.append((M1 + M2 * sin2) / sin2 * y_ddot(t) + M1 * cos * (K * s + d * s_dot) / (M2 * sin2))
    return steps, state[0], forces[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repetitions", type=int, default=3)
    arguments = parser.parse_args()
    for d in (1.0, 0.0):
        best = math.inf
        for _ in range(arguments.repetitions):
            start = time.perf_counter()
            steps, s_end, u_end = solve(d)
            best = min(best, time.perf_counter() - start)
        print(json.dumps({"method": "scipy-rk45", "d": d, "seconds": best, "steps": steps,
                          "s_end": s_end, "u_end": u_end}))


if __name__ == "__main__":
    main()
