#!/usr/bin/python3
"""SciPy peer of `servokit sweep` for the mass-on-car model (paper Sect. 3, Eqs. 26-36).

Sweeps alpha in [0, 90 deg] x d in [0, 2] (np.linspace, inclusive) and writes one row per
point in the layout of servokit's points.csv:

    alpha, d, realization, P_rank, relative_degree, differentiation_index,
    internal_dynamics_order, stability, max_real_part

written the way a SciPy user would, point by point: linearize at q = 0, u = 0, build the
first-order state space, take the invariant zeros as the finite generalized eigenvalues of
the Rosenbrock pencil (scipy.linalg.eig, i.e. LAPACK QZ), read the relative degree off the
Markov parameters C A^k Bs, and classify. Tolerances and verdict rules are servokit's
(analysis/options.h): a quantity is zero when at most 1e-10 times the product of its factors'
norms; an eigenvalue is on the imaginary axis when |Re| <= 1e-9 max |lambda|.

Prints one JSON line {"points", "seconds", "points_per_second"}; seconds cover the whole loop,
CSV writing included (not the interpreter start-up and imports). With --check, every point's
zeros are compared (after the timed loop) with the roots of m2 sin^2(a) s^2 + d s + k, the
zero-dynamics polynomial of Eq. (36); any mismatch beyond 1e-8 relative exits with status 1.

Run with Debian's Python, which has SciPy:
    /usr/bin/python3 bench/scipy_sweep.py --alpha-points 100 --d-points 100 --out /tmp/p.csv
"""
import argparse
import csv
import json
import math
import sys
import time

import numpy as np
import scipy.linalg

M1, M2, K_SPRING = 1.0, 2.0, 5.0  # models/mass_on_car.yaml
RANK_TOLERANCE = 1e-10            # servokit ClassificationOptions::rank_tolerance
AXIS_TOLERANCE = 1e-9             # servokit ClassificationOptions::imaginary_axis_tolerance
FINITE_TOLERANCE = 1e-10          # |beta| below this (relative) is an infinite eigenvalue
CHECK_TOLERANCE = 1e-8

COLUMNS = ["alpha", "d", "realization", "P_rank", "relative_degree", "differentiation_index",
           "internal_dynamics_order", "stability", "max_real_part"]


def linearize(alpha, d):
    """State space (A, Bs, C) of the mass on car at q = 0, u = 0, and the second-order H, B."""
    c = math.cos(alpha)
    M = np.array([[M1 + M2, M2 * c], [M2 * c, M2]])
    K = np.array([[0.0, 0.0], [0.0, K_SPRING]])
    D = np.array([[0.0, 0.0], [0.0, d]])
    B = np.array([[1.0], [0.0]])
    H = np.array([[1.0, c]])
    n = M.shape[0]
    Minv = scipy.linalg.inv(M)
    MinvB = Minv @ B
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    Bs = np.vstack([np.zeros((n, 1)), MinvB])
    C = np.hstack([H, np.zeros((1, n))])
    return A, Bs, C, H, B, MinvB


def invariant_zeros(A, Bs, C):
    """Finite generalized eigenvalues of the Rosenbrock pencil ([[A, B], [C, 0]], diag(I, 0))."""
    n, m = Bs.shape
    p = C.shape[0]
    pencil_a = np.block([[A, Bs], [C, np.zeros((p, m))]])
    pencil_b = np.zeros_like(pencil_a)
    pencil_b[:n, :n] = np.eye(n)
    w = scipy.linalg.eig(pencil_a, pencil_b, right=False, homogeneous_eigvals=True)
    alpha, beta = w[0], w[1]
    finite = np.abs(beta) > FINITE_TOLERANCE * np.hypot(np.abs(alpha), np.abs(beta))
    return alpha[finite] / beta[finite]


def relative_degree(A, Bs, C, max_k=3):
    """1 + the first k with C A^k Bs != 0 (relative to |C| |A|^k |Bs|, Frobenius norms as
    servokit); None if all are zero up to max_k."""
    norm_a = np.linalg.norm(A)
    scale = np.linalg.norm(C) * np.linalg.norm(Bs)
    AkB = Bs
    for k in range(max_k + 1):
        markov = C @ AkB
        if np.linalg.norm(markov) > RANK_TOLERANCE * scale * norm_a ** k:
            return k + 1
        AkB = A @ AkB
    return None


def realization(H, B, MinvB):
    """(realization, rank of P = H M^-1 B) as servokit's analysis/decoupling_matrix.cpp."""
    P = H @ MinvB
    sv = scipy.linalg.svdvals(P)
    rank = int(np.sum(sv > RANK_TOLERANCE * np.linalg.norm(H) * np.linalg.norm(MinvB)))
    outputs = H.shape[0]
    if rank == 0:
        return "tangential", rank
    if rank < outputs:
        return "mixed-orthogonal-tangential", rank
    T = scipy.linalg.null_space(H)  # tangent of the servo-constraint manifold
    share = np.linalg.norm(T.T @ B) / np.linalg.norm(B)
    return ("ideal-orthogonal" if share <= RANK_TOLERANCE else "non-ideal-orthogonal"), rank


def stability(zeros):
    """(verdict, max real part) with servokit's rule (analysis/zero_dynamics.cpp)."""
    if zeros.size == 0:
        return "none", float("nan")
    threshold = AXIS_TOLERANCE * np.max(np.abs(zeros))
    max_re = float(np.max(zeros.real))
    if max_re > threshold:
        return "unstable", max_re
    if max_re >= -threshold:
        return "critical", max_re
    return "asymptotically-stable", max_re


def analyze_point(alpha, d):
    A, Bs, C, H, B, MinvB = linearize(alpha, d)
    zeros = invariant_zeros(A, Bs, C)
    kind, rank = realization(H, B, MinvB)
    r = relative_degree(A, Bs, C)
    verdict, max_re = stability(zeros)
    row = [repr(alpha), repr(d), kind, rank,
           "" if r is None else r, "" if r is None else r + 1,
           zeros.size, verdict, "" if math.isnan(max_re) else repr(max_re)]
    return row, zeros


def closed_form_zeros(alpha, d):
    """Roots of m2 sin^2(a) s^2 + d s + k (np.roots drops exactly-zero leading coefficients)."""
    return np.roots([M2 * math.sin(alpha) ** 2, d, K_SPRING])


def check_point(alpha, d, zeros):
    """None if the QZ zeros match the closed form to CHECK_TOLERANCE relative, else a message."""
    expected = list(closed_form_zeros(alpha, d))
    if len(expected) != zeros.size:
        return f"{zeros.size} zeros, expected {len(expected)}: {zeros} vs {expected}"
    for z in zeros:  # greedy nearest match: conjugate pairs have no stable sort order
        i = min(range(len(expected)), key=lambda j: abs(expected[j] - z))
        error = abs(expected[i] - z) / abs(expected[i])
        if error > CHECK_TOLERANCE:
            return f"zero {z} vs closed form {expected[i]}: relative error {error:.3g}"
        expected.pop(i)
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--alpha-points", type=int, required=True)
    parser.add_argument("--d-points", type=int, required=True)
    parser.add_argument("--out", required=True, help="points.csv to write")
    parser.add_argument("--check", action="store_true",
                        help="verify every point's zeros against the closed form")
    args = parser.parse_args()
    if args.alpha_points < 1 or args.d_points < 1:
        parser.error("--alpha-points and --d-points must be >= 1")

    alphas = np.linspace(0.0, math.pi / 2, args.alpha_points)
    dampings = np.linspace(0.0, 2.0, args.d_points)
    kept = []

    start = time.perf_counter()
    with open(args.out, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        for alpha in alphas:  # first --vary varies slowest
            for d in dampings:
                row, zeros = analyze_point(float(alpha), float(d))
                writer.writerow(row)
                if args.check:
                    kept.append((float(alpha), float(d), zeros))
    seconds = time.perf_counter() - start

    points = args.alpha_points * args.d_points
    print(json.dumps({"points": points, "seconds": seconds,
                      "points_per_second": points / seconds}))

    if args.check:
        failures = 0
        worst = 0.0
        for alpha, d, zeros in kept:
            message = check_point(alpha, d, zeros)
            if message is not None:
                failures += 1
                if failures <= 10:
                    print(f"check: alpha={math.degrees(alpha):.6g} deg, d={d:.6g}: {message}",
                          file=sys.stderr)
            else:
                for z in zeros:
                    worst = max(worst, min(abs(e - z) / abs(e)
                                           for e in closed_form_zeros(alpha, d)))
        print(f"check: {points - failures}/{points} points match the closed form "
              f"(worst relative error {worst:.2e}, tolerance {CHECK_TOLERANCE:g})",
              file=sys.stderr)
        if failures:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
