#!/usr/bin/env bash
# Runs every benchmark of bench/ against the build in $1 (default: build).
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
echo "== analysis: model load and operating-point analyses (issue #2) =="
"$build/bench/bench_analysis" "$root/models" 1.0
echo
echo "== sweep throughput against the SciPy pipeline (issue #3) =="
"$root/bench/compare_sweep.sh" "$build"
echo
echo "== sweep threads: two against one, idle and beside a busy process (issue #19) =="
"$root/bench/compare_threads.sh" "$build"
echo
echo "== start-up: CPU time of analyze on every shipped model (issue #19) =="
"$root/bench/compare_startup.sh" "$build"
echo
echo "== model size: the symbolic core against issue #31's targets =="
"$root/bench/compare_model_size.sh" "$build"
echo
echo "== sweep of every shipped model against a generic per-point SciPy pipeline (issue #19) =="
"$root/bench/compare_generic_sweep.sh" "$build"
echo
echo "== sweep files: CSV against HDF5 and MAT (issue #17) =="
"$root/bench/compare_sweep_formats.sh" "$build"
echo
echo "== inverse-model solves against SciPy solve_ivp (issue #4) =="
"$root/bench/compare_solve.sh" "$build"
echo
echo "== paper case 3 (tangential) against SciPy solve_ivp on Eq. (40), equal accuracy (issue #15) =="
"$root/bench/compare_case3.sh" "$build"
echo
echo "== flat inverse of a linear double-pendulum crane (relative degree 6) against NumPy (issue #15) =="
"$root/bench/compare_flat_crane.sh" "$build"
echo
echo "== a closed chain's feedforward: the crane in absolute coordinates against NumPy (issue #32) =="
"$root/bench/compare_crane_absolute.sh" "$build"
echo
echo "== stable inversion against SciPy solve_bvp (issue #5) =="
"$root/bench/compare_stable_inversion.sh" "$build"
echo
echo "== a sampled trajectory against its closed form: cost linear in the samples (issue #29) =="
"$root/bench/compare_sampled_trajectory.sh" "$build"
echo
echo "== large linear models: ARPACK against scipy.sparse.linalg.eigs (issue #6) =="
"$root/bench/compare_large.sh" "$build"
echo
echo "== distributed sweeps: MPI efficiency at 2 ranks (issue #6) =="
if command -v mpirun >/dev/null; then
  "$root/bench/compare_mpi_sweep.sh" "$build"
else
  echo "mpirun not found: skipped"
fi
