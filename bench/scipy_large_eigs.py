#!/usr/bin/python3
"""SciPy peer of bench/large_model_bench.cpp: the k zero-dynamics eigenvalues nearest 0 of one
large linear model file (`servokit generate chain|beam ... --out DIR`, issue #6).

Reads the same YAML and Matrix Market files, assembles M, D, K at the nominal parameters (each
matrix the sum of factor * term; a factor is a product of parameter names and numbers, which is
all the generators write), builds the Rosenbrock pencil in first-order form the way a SciPy user
would,

        [  0   I  0 ]        [ I  0  0 ]
    A = [ -K  -D  B ],   E = [ 0  M  0 ]     (size 2n + m, unknowns (q, v, u)),
        [  C   0  0 ]        [ 0  0  0 ]

and calls scipy.sparse.linalg.eigs(A, k, M=E, sigma=0): ARPACK in shift-invert mode 3 with
SuperLU of A - 0 E (E is symmetric positive semi-definite, as eigs requires). Infinite
eigenvalues do not appear (they map to 0 under shift-invert).

Prints one JSON line like the C++ bench: {"model", "dof", "k", "load_seconds",
"assemble_seconds" (M, D, K and the pencil), "eigs_seconds", "seconds" (assemble + eigs),
"max_rss_mb" (getrusage of this process, the interpreter and NumPy included),
"eigenvalues": [[re, im], ...]}.

    /usr/bin/python3 bench/scipy_large_eigs.py DIR/chain_100000.yaml [K [NCV]]

NCV is ARPACK's basis size; compare_large.sh passes servokit's (max(2K + 10, 30)) so that both
run the same ARPACK iteration (SciPy's own default, max(2K + 1, 20), restarts far more often on
these spectra).
"""
import json
import os
import resource
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import yaml


def factor_value(text, parameters):
    value = 1.0
    for part in str(text).split("*"):
        part = part.strip()
        value *= parameters[part] if part in parameters else float(part)
    return value


def read_terms(directory, entry):
    """[(matrix, factor text)] of one matrix key (None when the key is absent)."""
    if entry is None:
        return None
    terms = entry if isinstance(entry, list) else [{"matrix": entry}]
    return [(scipy.io.mmread(os.path.join(directory, term["matrix"])).tocsc(),
             term.get("factor", 1)) for term in terms]


def assemble(terms, parameters, shape=None):
    if terms is None:
        return sp.csc_matrix(shape)
    total = None
    for matrix, factor in terms:
        matrix = factor_value(factor, parameters) * matrix
        total = matrix if total is None else total + matrix
    return total.tocsc()


TOLERANCE = 1e-12


def read_model(path):
    """The name, the parameters and the matrix terms (read_terms) of the linear model file."""
    directory = os.path.dirname(os.path.abspath(path))
    with open(path) as file:
        model = yaml.safe_load(file)
    parameters = {name: float(value) for name, value in (model.get("parameters") or {}).items()}
    terms = {key: read_terms(directory, model.get(key)) for key in
             ("mass_matrix", "damping_matrix", "stiffness_matrix", "input_matrix",
              "output_matrix")}
    return model.get("name"), parameters, terms


def print_result(name, n, k, ncv, load_seconds, assemble_seconds, eigs_seconds, values):
    """The peer's one JSON line: times, peak memory and the eigenvalues, largest real part first
    (the form compare_large.sh reads from both peers)."""
    values = sorted(values, key=lambda z: (-z.real, -z.imag))
    print(json.dumps({
        "model": name, "dof": n, "k": k, "ncv": ncv,
        "load_seconds": load_seconds, "assemble_seconds": assemble_seconds,
        "eigs_seconds": eigs_seconds, "seconds": assemble_seconds + eigs_seconds,
        "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "eigenvalues": [[float(z.real), float(z.imag)] for z in values],
    }))


def main():
    path = sys.argv[1]
    k = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    ncv = int(sys.argv[3]) if len(sys.argv) > 3 else None
    start = time.perf_counter()
    name, parameters, terms = read_model(path)
    load_seconds = time.perf_counter() - start

    start = time.perf_counter()
    mass = assemble(terms["mass_matrix"], parameters)
    n = mass.shape[0]
    stiffness = assemble(terms["stiffness_matrix"], parameters)
    damping = assemble(terms["damping_matrix"], parameters, (n, n))
    input_matrix = assemble(terms["input_matrix"], parameters)
    output_matrix = assemble(terms["output_matrix"], parameters)
    m = input_matrix.shape[1]
    identity = sp.identity(n, format="csc")
    pencil_a = sp.bmat([[None, identity, None],
                        [-stiffness, -damping, input_matrix],
                        [output_matrix, None, None]], format="csc")
    pencil_e = sp.block_diag([identity, mass, sp.csc_matrix((m, m))], format="csc")
    assemble_seconds = time.perf_counter() - start

    start = time.perf_counter()
    # The same ARPACK tolerance as servokit's default (ArpackOptions::tolerance).
    values = sla.eigs(pencil_a, k=k, M=pencil_e, sigma=0.0, ncv=ncv, tol=TOLERANCE,
                     return_eigenvectors=False)
    eigs_seconds = time.perf_counter() - start
    print_result(name, n, k, ncv, load_seconds, assemble_seconds, eigs_seconds, values)


if __name__ == "__main__":
    main()
