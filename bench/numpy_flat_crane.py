#!/usr/bin/env python3
"""The NumPy peer of `servokit solve tests/data/linear_double_pendulum_crane.yaml --method
algebraic`: the flat inverse of the linear double-pendulum crane written by hand, as a NumPy
user would. With A = M^-1 K and C A^k M^-1 B = 0 for k < 2:
    [C; C A; C A^2] q = [y; -y''; y''''],  the same for q' with y', y''', y^(5),
    u = (y^(6) + C A^2 M^-1 K q) / (C A^2 M^-1 B),
on the 1 ms grid of a 1 m move in 3 s (rest to rest with 6 continuous derivatives), 4 s in all.
Prints one JSON object: best time of several runs (the inverse alone, and with Python's start
measured by the caller), max |u|.
"""
import json
import math
import time

import numpy as np
from math import comb

MT, M1, M2, L1, L2, G = 5.0, 1.0, 2.0, 1.0, 0.5, 9.81
M = np.array([[MT + M1 + M2, (M1 + M2) * L1, M2 * L2],
              [(M1 + M2) * L1, (M1 + M2) * L1 ** 2, M2 * L1 * L2],
              [M2 * L2, M2 * L1 * L2, M2 * L2 ** 2]])
K = np.diag([0.0, (M1 + M2) * G * L1, M2 * G * L2])
B = np.array([1.0, 0.0, 0.0])
C = np.array([1.0, L1, L2])
T0, TF, TEND, CONTINUOUS = 0.0, 3.0, 4.0, 6


def rest_to_rest(k):
    """p_k(tau) = tau^(k+1) sum_j C(k+j, j) (1 - tau)^j as a polynomial in tau."""
    tau = np.polynomial.Polynomial([0, 1])
    return tau ** (k + 1) * sum(comb(k + j, j) * (1 - tau) ** j for j in range(k + 1))


def inverse():
    p = rest_to_rest(CONTINUOUS)
    t = np.linspace(T0, TEND, 4001)
    tau = np.clip((t - T0) / (TF - T0), 0.0, 1.0)
    inside = (t > T0) & (t < TF)
    y = [p(tau)] + [np.where(inside, p.deriv(n)(tau) / (TF - T0) ** n, 0.0) for n in range(1, 7)]
    a = np.linalg.solve(M, K)
    observability = np.vstack([C, C @ a, C @ a @ a])
    q = np.linalg.solve(observability, np.vstack([y[0], -y[2], y[4]]))
    top = C @ a @ a @ np.linalg.inv(M)
    return (y[6] + (top @ K) @ q) / (top @ B)


def main():
    best = math.inf
    for _ in range(20):
        start = time.perf_counter()
        u = inverse()
        best = min(best, time.perf_counter() - start)
    print(json.dumps({"seconds": best, "max_u": float(np.max(np.abs(u)))}))


if __name__ == "__main__":
    main()
