#pragma once
// Sweeps of large linear models (issue #6): AnalyzeLinearSystem at every point of a
// ParameterGrid, recorded as the SweepPoint of a nonlinear sweep so that the same files (and the
// same MPI distribution) serve both kinds.
//
// The sparsity pattern of M, D, K (and so of the Rosenbrock matrix) is the union of the terms'
// patterns whatever the parameter values (models/linear_model.h). So each thread keeps one
// LinearZeroDynamicsWorkspace for all its points: the pattern of the Rosenbrock matrix is
// analysed (COLAMD, symbolic SparseLU) once per thread, and every later point only refactorises.
#include <Eigen/Dense>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "analysis/linear_analysis.h"
#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "analysis/sweep_point.h"
#include "models/linear_model.h"

namespace servokit {

struct LinearSweepOptions {
  LinearAnalysisOptions analysis;
  // Threads; 0 means OpenMP's default. Points per block (>= 1); the results depend on neither.
  int threads = 0;
  std::size_t block_size = kSweepBlockSize;
};

/// One point: assembles the system at `parameters` and analyses it with `workspace` (reused
/// from point to point). A point without a solution (NoSolution: singular M, singular
/// decoupling matrix, an eigensolver that fails) is recorded in the SweepPoint (ok = false, the
/// one-line message in `error`), as AnalyzeSweepPoint does. The class columns: realization and
/// rank of P, relative degrees, differentiation index, internal dynamics order (-1 when the
/// relative degrees are not determined numerically, which the CSV writes as three empty
/// columns), stability and max_real_part of the zeros computed; `eigenvalues` are the zeros
/// computed (all of them, or the k nearest the shift with ARPACK), sorted by SortEigenvalues.
/// ARPACK is not reentrant (Fortran SAVE state): points on the ARPACK route are analysed one at a
/// time in a process (a lock); their assembly runs in parallel. Processes (mpirun) scale.
SweepPoint AnalyzeLinearSweepPoint(const LinearModel& model,
                                   const Eigen::VectorXd& parameters,
                                   LinearZeroDynamicsWorkspace& workspace,
                                   const LinearAnalysisOptions& options);

/// The workspaces of a linear sweep, one per thread, kept across blocks (and across the calls of
/// RunLinearSweep that an MPI rank makes for its blocks).
class LinearSweepWorkspaces {
 public:
  explicit LinearSweepWorkspaces(int threads);
  int threads() const { return static_cast<int>(workspaces_.size()); }
  LinearZeroDynamicsWorkspace& operator[](int thread) {
    return *workspaces_[static_cast<std::size_t>(thread)];
  }
  /// Pattern analyses (symbolic factorisations) done by each thread's workspace so far.
  std::vector<int> pattern_analyses() const;

 private:
  std::vector<std::unique_ptr<LinearZeroDynamicsWorkspace>> workspaces_;
};

/// As RunSweep (analysis/sweep.h) for a linear model: analyses points first_point.. of `grid`
/// (the model's parameters where the grid does not vary them) in blocks, in parallel within a
/// block with workspaces[thread], and hands each block to `consume` on the calling thread.
/// Returns the index after the last point consumed. Throws UsageError for bad options.
std::size_t RunLinearSweep(const LinearModel& model,
                           const ParameterGrid& grid,
                           const LinearSweepOptions& options,
                           std::size_t first_point,
                           LinearSweepWorkspaces& workspaces,
                           const SweepConsumer& consume);

/// The same with workspaces of its own (SweepThreads of the options' threads).
std::size_t RunLinearSweep(const LinearModel& model,
                           const ParameterGrid& grid,
                           const LinearSweepOptions& options,
                           std::size_t first_point,
                           const SweepConsumer& consume);

/// The analysis options as one line, for fingerprints and sweep.json: everything that decides
/// the bytes of a linear sweep's files.
std::string DescribeLinearSweepOptions(const LinearAnalysisOptions& options);

}  // namespace servokit
