#!/usr/bin/env python3
"""The NumPy peer of `servokit solve models/gantry_crane_absolute.yaml` (issue #32: a closed
chain): the crane in absolute coordinates (trolley x, rope payout r, load (xL, zL), the rope a
loop constraint (xL - x)^2 + zL^2 - (L0 + r)^2 = 0) inverted in closed form by hand, as a NumPy
user would, from the load's equations of motion:
    m xL'' = 2 (xL - x) lambda,  m zL'' - m g = 2 zL lambda
give lambda = m (zL'' - g) / (2 zL), xL - x = m xL'' / (2 lambda), the constraint L0 + r, and
    F = mt x'' + 2 (xL - x) lambda,  W = mw r'' + 2 (L0 + r) lambda,
with x'' and r'' carried through by the product, quotient and square-root rules (value, first
and second derivative of every quantity). On the 1 ms grid of the load moved 1 m out in 3 s at
a constant depth of 2 m (Eq. 65, rest to rest), 4 s in all. Prints one JSON object: the best
time of several runs of the inverse alone, and F, W, lambda at t = 1 s (the check).
"""
import json
import time
from math import comb

import numpy as np

MT, MW, M, G, L0 = 10.0, 2.0, 5.0, 9.81, 2.0
T0, TF, TEND, CONTINUOUS = 0.0, 3.0, 4.0, 4
X0, XF, DEPTH = 0.0, 1.0, 2.0


def rest_to_rest(k):
    """p_k(tau) = tau^(k+1) sum_j C(k+j, j) (1 - tau)^j as a polynomial in tau."""
    tau = np.polynomial.Polynomial([0, 1])
    return tau ** (k + 1) * sum(comb(k + j, j) * (1 - tau) ** j for j in range(k + 1))


def load_motion(t):
    """xL and its first four derivatives on t (zero outside the motion)."""
    p = rest_to_rest(CONTINUOUS)
    tau = np.clip((t - T0) / (TF - T0), 0.0, 1.0)
    inside = (t > T0) & (t < TF)
    derivatives = []
    for order in range(5):
        value = (XF - X0) * p.deriv(order)(tau) / (TF - T0) ** order if order else \
            X0 + (XF - X0) * p(tau)
        derivatives.append(value if order == 0 else np.where(inside, value, 0.0))
    return derivatives


def inverse(t):
    """F, W, lambda on t."""
    x, x1, x2, x3, x4 = load_motion(t)
    # zL = DEPTH: its derivatives vanish; lambda is constant, -m g / (2 zL).
    multiplier = np.full_like(t, M * (0.0 - G) / (2 * DEPTH))
    offset, offset1, offset2 = (M * a / (2 * multiplier) for a in (x2, x3, x4))  # xL - x
    trolley2 = x2 - offset2
    rope = np.sqrt(offset ** 2 + DEPTH ** 2)  # L0 + r
    rope1 = offset * offset1 / rope
    rope2 = (offset1 ** 2 + offset * offset2 - rope1 ** 2) / rope
    force = MT * trolley2 + 2 * offset * multiplier
    winch = MW * rope2 + 2 * rope * multiplier
    return force, winch, multiplier


def main():
    t = np.linspace(0.0, TEND, int(round(TEND / 1e-3)) + 1)
    best = float("inf")
    for _ in range(20):
        start = time.perf_counter()
        force, winch, multiplier = inverse(t)
        best = min(best, time.perf_counter() - start)
    i = int(round(1.0 / 1e-3))
    print(json.dumps({"seconds": best, "F": force[i], "W": winch[i], "lambda": multiplier[i]}))


if __name__ == "__main__":
    main()
