#!/usr/bin/python3
"""SciPy bordered peer of bench/large_model_bench.cpp (issue #19): the k zero-dynamics
eigenvalues nearest the shift sigma of one large linear model file, with the border (B, C) of the
Rosenbrock matrix applied through its Schur complement, the way a SciPy user handles an output
that mixes many coordinates (a dense row of C, `servokit generate chain --output-weights linear`),
where a sparse LU of the bordered matrix fills in.

With Q = K + sigma D + sigma^2 M, the shift-inverted operator OP = (A - sigma E)^-1 E on (q, v)
(bench/scipy_large_eigs.py's pencil, eliminated as in analysis/linear_zero_dynamics.h) is

    r = M w2 + (D + sigma M) w1,   z = Q^-1 r,   u = S^-1 (C z),   q = W u - z,   v = w1 + sigma q,

with W = Q^-1 B (dense n x m) and S = C W (m x m): one SuperLU (scipy.sparse.linalg.splu) of Q,
a dense LU (scipy.linalg.lu_factor) of S, and scipy.sparse.linalg.eigs on a LinearOperator
(ARPACK 'LM', regular mode), whose eigenvalues nu give lambda = sigma + 1/nu.

Prints one JSON line like the C++ bench: {"model", "dof", "k", "load_seconds",
"assemble_seconds" (M, D, K, Q, the LU of Q, W and S), "eigs_seconds", "seconds"
(assemble + eigs), "max_rss_mb" (getrusage of this process, the interpreter and NumPy included),
"eigenvalues": [[re, im], ...]}.

    /usr/bin/python3 bench/scipy_bordered_eigs.py DIR/chain_100000.yaml [K [NCV [SIGMA]]]
"""
import os
import sys
import time

import numpy as np
import scipy.linalg
import scipy.sparse.linalg as sla

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scipy_large_eigs import TOLERANCE, assemble, print_result, read_model  # noqa: E402

# The same fixed start vector on every run (ARPACK's own is random), so runs repeat.
SEED = 20130613
# A computed nu at most this times the largest |nu| is an infinite eigenvalue (servokit's
# LinearZeroDynamicsOptions::infinite_tolerance).
INFINITE_TOLERANCE = 1e-6


def main():
    path = sys.argv[1]
    k = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    ncv = int(sys.argv[3]) if len(sys.argv) > 3 else None
    sigma = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    start = time.perf_counter()
    name, parameters, terms = read_model(path)
    load_seconds = time.perf_counter() - start

    start = time.perf_counter()
    mass = assemble(terms["mass_matrix"], parameters)
    n = mass.shape[0]
    stiffness = assemble(terms["stiffness_matrix"], parameters)
    damping = assemble(terms["damping_matrix"], parameters, (n, n))
    input_matrix = assemble(terms["input_matrix"], parameters)
    output_matrix = assemble(terms["output_matrix"], parameters).tocsr()
    dynamic = (stiffness + sigma * damping + sigma * sigma * mass).tocsc()
    damping_plus_shift_mass = (damping + sigma * mass).tocsr()
    mass = mass.tocsr()
    lu = sla.splu(dynamic)
    input_solution = lu.solve(input_matrix.toarray())  # W = Q^-1 B
    schur = scipy.linalg.lu_factor(output_matrix @ input_solution)  # S = C W

    def apply(x):
        x = np.asarray(x).ravel()
        w1, w2 = x[:n], x[n:]
        z = lu.solve(mass @ w2 + damping_plus_shift_mass @ w1)
        u = scipy.linalg.lu_solve(schur, output_matrix @ z)
        q = input_solution @ u - z
        return np.concatenate([q, w1 + sigma * q])

    operator = sla.LinearOperator((2 * n, 2 * n), matvec=apply, dtype=float)
    assemble_seconds = time.perf_counter() - start

    start = time.perf_counter()
    v0 = apply(np.random.default_rng(SEED).uniform(-1.0, 1.0, 2 * n))
    nus = sla.eigs(operator, k=k, which="LM", ncv=ncv, tol=TOLERANCE, v0=v0,
                   return_eigenvectors=False)
    eigs_seconds = time.perf_counter() - start
    scale = max(abs(nus))
    values = [sigma + 1.0 / nu for nu in nus if abs(nu) > INFINITE_TOLERANCE * scale]
    print_result(name, n, k, ncv, load_seconds, assemble_seconds, eigs_seconds, values)


if __name__ == "__main__":
    main()
