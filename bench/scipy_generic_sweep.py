#!/usr/bin/python3
"""Generic SciPy peer of `servokit sweep` for any multibody model file (issue #19).

Reads a model YAML (parameters, coordinates, inputs, mass_matrix M, forces f, input_matrix B,
outputs h, as expressions; or `kind: lagrangian` with T, V and D, differentiated by SymPy; and
a closed chain's `constraints` c(q) with the file's `q0`), compiles every expression once with
sympy.lambdify (NumPy backend), and sweeps a full grid the way a SciPy user would write it for
any model, point by point:

  1. operating point: q = q0 (the file's, else 0), velocities 0, y0 = h(q0), u0 = least
     squares of [B, C^T] [u; lambda] = f; if the equilibrium residual [f(q, 0) - B(q) u - C(q)^T lambda;
     h(q) - y0; c(q)] is not zero there, Newton on (q, u, lambda) with a complex-step
     Jacobian. A closed chain is analysed on the tangent space of c = 0 (T = null_space(C):
     T^T M T, T^T K T, T^T D T, T^T B, H T, K with d(C^T lambda0)/dq);
  2. linearization by complex-step Jacobians (step 1e-20i): K = d(f - B u0)/dq,
     D = df/dq_dot, H = dh/dq;
  3. invariant zeros: the finite generalized eigenvalues of the Rosenbrock pencil
     [[0, I, 0], [-K, -D, B], [H, 0, 0]] - s diag(I, M, 0) (scipy.linalg.eig, LAPACK QZ);
  4. P = H M^-1 B, its rank (SVD) and the realization; per-output relative degrees from the
     Markov parameters C_i A^k B of the first-order system;
  5. the stability verdict of the zeros;

and writes points.csv and eigenvalues.csv in servokit's layout (numbers as repr). Model
conventions are servokit's (docs/model-files.md): M(q) q'' + f(q, q_dot) = B(q) u, velocities
named <coordinate>_dot, ^ for powers, parameters in SI or "<number> deg". Tolerances and verdict
rules are servokit's (analysis/options.h): a quantity is zero when at most 1e-10 times the
product of its factors' norms; an eigenvalue is on the imaginary axis when its damping ratio
|Re| / |lambda| is at most 1e-9 or |Re| <= 1e-12 max |lambda|.

The grid is given as servokit's: --vary p=a:b:n (n values, a and b included, numpy.linspace;
a and b may end in "deg"), points row-major (the first --vary varies slowest).

Prints one JSON line {"points", "seconds", "points_per_second"}: seconds is the CPU time
(time.process_time) of the loop, CSV writing included; not the interpreter start-up, the
imports, reading the model nor compiling its expressions. With --check DIR (a servokit sweep
of the same model and grid), every point's classes (realization, P_rank, relative degrees,
internal dynamics order, stability) and zeros (relative 1e-8 of max(1, |z|)) are compared with
DIR/points.csv and DIR/eigenvalues.csv after the timed loop; a mismatch exits with status 1.

Run with Debian's Python (python3-scipy, python3-sympy, python3-yaml):
    /usr/bin/python3 bench/scipy_generic_sweep.py models/gantry_crane.yaml \
        --vary m=1:10:n=50 --vary L0=1:5:n=50 --out /tmp/peer
"""
import argparse
import csv
import itertools
import json
import math
import os
import sys
import time

import numpy as np
import scipy.linalg
import sympy
import yaml
from sympy.parsing.sympy_parser import (convert_xor, parse_expr, standard_transformations)

RANK_TOLERANCE = 1e-10    # servokit ClassificationOptions::rank_tolerance
AXIS_TOLERANCE = 1e-9     # servokit ClassificationOptions::imaginary_axis_tolerance
ZERO_FLOOR = 1e-12        # servokit kZeroEigenvalueFloor
RESIDUAL_TOLERANCE = 1e-10
NEWTON_ITERATIONS = 50
STEP = 1e-20              # complex step
CHECK_TOLERANCE = 1e-8

POINT_COLUMNS = ["realization", "P_rank", "relative_degree", "differentiation_index",
                 "internal_dynamics_order", "stability", "max_real_part", "error"]
EIGEN_COLUMNS = ["eigenvalue_index", "re", "im", "frequency_hz", "damping_ratio"]


def number(text):
    """A number in SI or '<number> deg' (radians)."""
    text = str(text).strip()
    if text.endswith("deg"):
        return math.radians(float(text[:-3]))
    return float(text)


class CompiledModel:
    """The model file's expressions, each compiled once into a NumPy function of (q, v, p)."""

    def __init__(self, path):
        with open(path) as f:
            doc = yaml.safe_load(f)
        self.name = doc["name"]
        self.parameter_names = list(doc["parameters"])
        self.parameters = np.array([number(doc["parameters"][p]) for p in self.parameter_names])
        self.coordinates = list(doc["coordinates"])
        self.inputs = list(doc["inputs"])
        n, m = len(self.coordinates), len(self.inputs)
        symbols = {name: sympy.Symbol(name) for name in
                   self.parameter_names + self.coordinates + [c + "_dot" for c in self.coordinates]}
        symbols["pi"] = sympy.pi
        transformations = standard_transformations + (convert_xor,)

        def parse(expression):
            return parse_expr(str(expression), local_dict=symbols, transformations=transformations)

        q = [symbols[c] for c in self.coordinates]
        v = [symbols[c + "_dot"] for c in self.coordinates]
        p = [symbols[name] for name in self.parameter_names]

        def compile_matrix(rows, shape):
            matrix = sympy.Matrix([[parse(e) for e in row] for row in rows])
            assert matrix.shape == shape, (matrix.shape, shape)
            return sympy.lambdify([q, v, p], matrix, modules="numpy", cse=True)

        def compile_vector(entries):
            vector = sympy.Matrix([parse(e) for e in entries])
            return sympy.lambdify([q, v, p], vector, modules="numpy", cse=True)

        if doc.get("kind") == "lagrangian":
            # Lagrange's equations from T, V and Rayleigh's D: M = d2T/dv2,
            # f = d2T/dv dq v - dT/dq + dV/dq + dD/dv.
            if "generalized_forces" in doc:
                raise ValueError("generalized_forces: not read by this peer")
            kinetic = parse(doc["kinetic_energy"])
            potential = parse(doc["potential_energy"])
            dissipation = parse(doc.get("dissipation", 0))
            momenta = sympy.Matrix([sympy.diff(kinetic, vk) for vk in v])
            forces = (momenta.jacobian(q) * sympy.Matrix(v)
                      - sympy.Matrix([sympy.diff(kinetic, qk) for qk in q])
                      + sympy.Matrix([sympy.diff(potential, qk) for qk in q])
                      + sympy.Matrix([sympy.diff(dissipation, vk) for vk in v]))
            self.mass_matrix = sympy.lambdify([q, v, p], momenta.jacobian(v), modules="numpy",
                                              cse=True)
            self.forces = sympy.lambdify([q, v, p], forces, modules="numpy", cse=True)
        else:
            self.mass_matrix = compile_matrix(doc["mass_matrix"], (n, n))
            self.forces = compile_vector(doc["forces"])
        self.input_matrix = compile_matrix(doc["input_matrix"], (n, m))
        self.outputs = compile_vector(doc["outputs"])
        # A closed chain's loop constraints c(q) = 0 (M q'' + f = B u + C^T lambda) and their
        # Jacobian C, and the file's start for Newton (q = 0 without one).
        constraints = sympy.Matrix([parse(e) for e in doc.get("constraints", [])])
        self.constraints = sympy.lambdify([q, v, p], constraints, modules="numpy", cse=True)
        self.constraint_jacobian = sympy.lambdify(
            [q, v, p], constraints.jacobian(q) if constraints.rows else sympy.zeros(0, n),
            modules="numpy", cse=True)
        self.start = np.array([number(x) for x in doc.get("q0", [0] * n)], dtype=float)
        self.dof, self.num_inputs, self.num_outputs = n, m, len(doc["outputs"])
        self.num_constraints = constraints.rows

    # Each returns a 2-D array (column vectors are n x 1); complex arguments give complex ones.
    def M(self, q, p):
        return np.asarray(self.mass_matrix(q, q * 0, p), dtype=q.dtype)

    def B(self, q, p):
        return np.asarray(self.input_matrix(q, q * 0, p), dtype=q.dtype)

    def f(self, q, v, p):
        return np.asarray(self.forces(q, v, p), dtype=np.result_type(q, v)).ravel()

    def h(self, q, p):
        return np.asarray(self.outputs(q, q * 0, p), dtype=q.dtype).ravel()

    def c(self, q, p):
        if not self.num_constraints:
            return np.zeros(0, dtype=q.dtype)
        return np.asarray(self.constraints(q, q * 0, p), dtype=q.dtype).ravel()

    def C(self, q, p):
        if not self.num_constraints:
            return np.zeros((0, q.size), dtype=q.dtype)
        return np.asarray(self.constraint_jacobian(q, q * 0, p), dtype=q.dtype)


def complex_step_jacobian(function, x):
    """d function / dx at a real x, column by column: Im(function(x + i STEP e_k)) / STEP."""
    columns = []
    for k in range(x.size):
        shifted = x.astype(complex)
        shifted[k] += STEP * 1j
        columns.append(function(shifted).imag / STEP)
    return np.column_stack(columns)


def operating_point(model, p):
    """(q, u, lambda): the equilibrium at rest holding y0 = h(q0) (q0 the file's start, else 0),
    Newton from q0 if needed on [f(q, 0) - B u - C^T lambda; h(q) - y0; c(q)]."""
    n, m, k = model.dof, model.num_inputs, model.num_constraints
    q = model.start.copy()
    y0 = model.h(q, p)
    # u and lambda that best balance the forces there: [B, C^T] [u; lambda] = f.
    forces_at_rest = np.linalg.lstsq(np.hstack([model.B(q, p), model.C(q, p).T]),
                                     model.f(q, q, p), rcond=None)[0]
    if model.num_outputs != m:
        raise ValueError("not square")

    def residual(x):
        qx, ux, lx = x[:n], x[n:n + m], x[n + m:]
        return np.concatenate([
            model.f(qx, qx * 0, p) - model.B(qx, p) @ ux - model.C(qx, p).T @ lx,
            model.h(qx, p) - y0, model.c(qx, p)])

    x = np.concatenate([q, forces_at_rest])
    r = residual(x)
    for _ in range(NEWTON_ITERATIONS):
        if np.max(np.abs(r)) <= RESIDUAL_TOLERANCE * max(1.0, np.max(np.abs(model.f(q, q, p)))):
            return x[:n], x[n:n + m], x[n + m:]
        x = x - np.linalg.solve(complex_step_jacobian(residual, x), r)
        r = residual(x)
    raise ArithmeticError("no equilibrium found")


def linearize(model, p):
    """M, K, D, B, H at the operating point; for a closed chain on the tangent space of c = 0:
    T^T M T, T^T K T, T^T D T, T^T B, H T, T an orthonormal null-space basis of C, with the
    loop forces' stiffness in K = d(f - B u0 - C^T lambda0)/dq."""
    q0, u0, lambda0 = operating_point(model, p)
    zero = np.zeros_like(q0)
    K = complex_step_jacobian(
        lambda q: model.f(q, zero, p) - model.B(q, p) @ u0 - model.C(q, p).T @ lambda0, q0)
    D = complex_step_jacobian(lambda v: model.f(q0, v, p), zero)
    H = complex_step_jacobian(lambda q: model.h(q, p), q0)
    M, B = model.M(q0, p), model.B(q0, p)
    if model.num_constraints:
        T = scipy.linalg.null_space(model.C(q0, p))
        return T.T @ M @ T, T.T @ K @ T, T.T @ D @ T, T.T @ B, H @ T
    return M, K, D, B, H


def invariant_zeros(M, K, D, B, H, count=None):
    """Finite generalized eigenvalues of the Rosenbrock pencil in first-order form. QZ leaves
    the infinite eigenvalues of a Jordan block of order k perturbed by about eps^(1/k): on
    the gantry crane some come out near 1e7 with |beta| far above any threshold. When the
    number of finite zeros is known (count: 2 dof - sum of the relative degrees, for a square
    system whose decoupling matrix is regular) the count smallest of them are kept."""
    n, m = B.shape
    p = H.shape[0]
    size = 2 * n + m
    pencil_a = np.zeros((2 * n + p, size))
    pencil_a[:n, n:2 * n] = np.eye(n)
    pencil_a[n:2 * n, :n] = -K
    pencil_a[n:2 * n, n:2 * n] = -D
    pencil_a[n:2 * n, 2 * n:] = B
    pencil_a[2 * n:, :n] = H
    pencil_e = np.zeros_like(pencil_a)
    pencil_e[:n, :n] = np.eye(n)
    pencil_e[n:2 * n, n:2 * n] = M
    alpha, beta = scipy.linalg.eig(pencil_a, pencil_e, right=False, homogeneous_eigvals=True)
    finite = np.abs(beta) > RANK_TOLERANCE * np.linalg.norm(pencil_e)
    zeros = alpha[finite] / beta[finite]
    if count is not None and zeros.size > count:
        zeros = zeros[np.argsort(np.abs(zeros), kind="stable")[:count]]
    return zeros


def relative_degrees(A, Bs, C):
    """Per output, 1 + the first k with |C_i A^k Bs| > tol |C_i A^k| |Bs|; and those rows."""
    degrees, rows = [], []
    input_size = np.linalg.norm(Bs)
    for i in range(C.shape[0]):
        row = C[i]
        for k in range(A.shape[0]):
            markov = row @ Bs
            if np.linalg.norm(markov) > RANK_TOLERANCE * np.linalg.norm(row) * input_size:
                degrees.append(k + 1)
                rows.append(markov)
                break
            row = row @ A
        else:
            raise ArithmeticError(f"output y{i + 1} is not influenced by the inputs")
    return degrees, np.array(rows)


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
    T = scipy.linalg.null_space(H, rcond=RANK_TOLERANCE)  # tangent of the constraint manifold
    share = np.linalg.norm(T.T @ B) / np.linalg.norm(B)
    return ("ideal-orthogonal" if share <= RANK_TOLERANCE else "non-ideal-orthogonal"), rank


def clean_and_sort(zeros):
    """servokit's CleanRoundOff and SortEigenvalues: parts at round-off level become 0, then
    real part descending, imaginary part descending."""
    if zeros.size == 0:
        return zeros
    magnitude = np.abs(zeros)
    floor = ZERO_FLOOR * np.max(magnitude)
    allowed = np.maximum(AXIS_TOLERANCE * magnitude, floor)
    re = np.where(np.abs(zeros.real) <= allowed, 0.0, zeros.real)
    im = np.where(np.abs(zeros.imag) <= allowed, 0.0, zeros.imag)
    order = np.lexsort((-im, -re))
    return re[order] + 1j * im[order]


def stability(zeros):
    """servokit's verdict: on the axis when |Re| <= max(1e-9 |z|, 1e-12 max |z|)."""
    if zeros.size == 0:
        return "none"
    magnitude = np.abs(zeros)
    allowed = np.maximum(AXIS_TOLERANCE * magnitude, ZERO_FLOOR * np.max(magnitude))
    if np.any(zeros.real > allowed):
        return "unstable"
    if np.any(np.abs(zeros.real) <= allowed):
        return "critical"
    return "asymptotically-stable"


def analyze_point(model, p):
    """(points row without the parameter columns, zeros)."""
    M, K, D, B, H = linearize(model, p)
    n = M.shape[0]  # dof - constraints for a closed chain
    Minv = scipy.linalg.inv(M)
    MinvB = Minv @ B
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    Bs = np.vstack([np.zeros_like(MinvB), MinvB])
    C = np.hstack([H, np.zeros_like(H)])
    kind, rank = realization(H, B, MinvB)
    degrees, decoupling = relative_degrees(A, Bs, C)
    regular = (decoupling.shape[0] == decoupling.shape[1] and
               np.sum(scipy.linalg.svdvals(decoupling) > RANK_TOLERANCE *
                      np.linalg.norm(decoupling)) == len(degrees))
    count = 2 * n - sum(degrees) if regular else None
    zeros = clean_and_sort(invariant_zeros(M, K, D, B, H, count))
    index = max(degrees) + 1 if regular else ""  # higher infinite zero orders: not derived here
    verdict = stability(zeros)
    max_re = repr(float(zeros.real[0])) if zeros.size else ""
    row = [kind, rank, ";".join(map(str, degrees)), index, zeros.size, verdict, max_re, ""]
    return row, zeros


def parse_axis(text):
    name, _, spec = text.partition("=")
    a, b, n = spec.split(":")
    n = int(n[2:] if n.startswith("n=") else n)
    unit = "deg" if (a.strip().endswith("deg") or b.strip().endswith("deg")) else ""
    return name, np.linspace(number(a), number(b), n), unit


def read_servokit(directory, parameter_columns):
    """servokit's points (list of dicts) and each point's zeros keyed by its parameter texts."""
    with open(os.path.join(directory, "points.csv"), newline="") as f:
        points = list(csv.DictReader(f))
    zeros = {}
    with open(os.path.join(directory, "eigenvalues.csv"), newline="") as f:
        for row in csv.DictReader(f):
            key = tuple(row[c] for c in parameter_columns)
            zeros.setdefault(key, []).append(complex(float(row["re"]), float(row["im"])))
    return points, zeros


def check(points, kept, servokit_dir, parameter_columns):
    """Compares every kept point with servokit's; returns the number of mismatches."""
    theirs, their_zeros = read_servokit(servokit_dir, parameter_columns)
    if len(theirs) != len(kept):
        print(f"check: servokit has {len(theirs)} points, the peer {len(kept)}", file=sys.stderr)
        return 1
    failures, worst, compared = 0, 0.0, 0
    for their, (row, zeros) in zip(theirs, kept):
        key = tuple(their[c] for c in parameter_columns)
        message = None
        fields = ["realization", "P_rank", "relative_degree", "internal_dynamics_order",
                  "stability"]
        ours = dict(zip(POINT_COLUMNS, row))
        for field in fields:
            if str(ours[field]) != their[field]:
                message = f"{field}: peer {ours[field]!r}, servokit {their[field]!r}"
                break
        if message is None:
            expected = list(their_zeros.get(key, []))
            if len(expected) != zeros.size:
                message = f"{zeros.size} zeros, servokit {len(expected)}"
            for z in zeros if message is None else []:
                j = min(range(len(expected)), key=lambda i: abs(expected[i] - z))
                error = abs(expected[j] - z) / max(1.0, abs(z))
                worst = max(worst, error)
                compared += 1
                if error > CHECK_TOLERANCE:
                    message = f"zero {z} vs servokit {expected[j]}: relative error {error:.3g}"
                    break
                expected.pop(j)
        if message is not None:
            failures += 1
            if failures <= 10:
                print(f"check: point {dict(zip(parameter_columns, key))}: {message}",
                      file=sys.stderr)
    print(f"check: {len(kept) - failures}/{len(kept)} points agree with servokit "
          f"({compared} zeros, worst relative difference {worst:.2e}, tolerance "
          f"{CHECK_TOLERANCE:g})", file=sys.stderr)
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model")
    parser.add_argument("--vary", action="append", required=True, help="p=a:b:n")
    parser.add_argument("--out", required=True, help="directory for points.csv, eigenvalues.csv")
    parser.add_argument("--check", metavar="DIR", help="servokit's sweep of the same grid")
    args = parser.parse_args()

    model = CompiledModel(args.model)
    axes = [parse_axis(v) for v in args.vary]
    indices = [model.parameter_names.index(name) for name, _, _ in axes]
    parameter_columns = [name + ("_deg" if unit else "") for name, _, unit in axes]
    os.makedirs(args.out, exist_ok=True)
    p = model.parameters.copy()
    kept = []

    start = time.process_time()
    with open(os.path.join(args.out, "points.csv"), "w", newline="") as pf, \
            open(os.path.join(args.out, "eigenvalues.csv"), "w", newline="") as ef:
        points_csv, eigen_csv = csv.writer(pf), csv.writer(ef)
        points_csv.writerow(parameter_columns + POINT_COLUMNS)
        eigen_csv.writerow(parameter_columns + EIGEN_COLUMNS)
        for values in itertools.product(*(grid for _, grid, _ in axes)):
            p[indices] = values
            shown = [repr(math.degrees(x) if unit else float(x))
                     for x, (_, _, unit) in zip(values, axes)]
            try:
                row, zeros = analyze_point(model, p)
            except (ArithmeticError, np.linalg.LinAlgError, ValueError) as error:
                row, zeros = [""] * 7 + [f'"{error}"'], np.zeros(0, complex)
            points_csv.writerow(shown + row)
            for k, z in enumerate(zeros):
                magnitude = abs(z)
                eigen_csv.writerow(shown + [k, repr(z.real), repr(z.imag),
                                            repr(magnitude / (2 * math.pi)),
                                            repr(-z.real / magnitude if magnitude else 1.0)])
            if args.check:
                kept.append((row, zeros))
    seconds = time.process_time() - start

    points = len(kept) if args.check else int(np.prod([len(g) for _, g, _ in axes]))
    print(json.dumps({"points": points, "seconds": seconds,
                      "points_per_second": points / seconds}))
    if args.check and check(points, kept, args.check, parameter_columns):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
