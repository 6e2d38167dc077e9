#pragma once
// The structure algorithm on the nonlinear model: how the outputs determine the state and the
// inputs along a motion (Silverman 1969; Isidori, Nonlinear Control Systems, Sect. 5.4 and the
// dynamic extension of Sect. 5.4-5.5). Symbolic (GiNaC), derived once per model.
//
// Each output equation starts as h_i(q) - y_i_d = 0 and is differentiated along the motion,
// q'' = M^-1 (B u - f), with the symbols Y_ik = y_i_d^(k) differentiating to Y_i(k+1). While
// its derivative is free of u it is a constraint on the state (q, q'), given Y; the first
// derivative in which u appears (at the relative degree r_i) is an input equation
//   0 = drift_i(q, q', Y) + a_i(q, q') u.
// When the matrix A of the rows a_i is regular the algorithm stops: the vector relative degree
// exists (an orthogonal realization has every r_i = 2 and A = P). When A has rank rho < m on a
// neighbourhood (a mixed realization: the gantry crane's load accelerations both follow the
// rope tension alone; the PVTOL's both follow the thrust), rho rows R whose block A_RC is
// regular at the reference state are kept, and every other row d is replaced by
//   g_d = drift_d - A_dC A_RC^-1 drift_R,
// free of u: a new constraint, differentiated further until u appears in it again. In the
// dynamic-extension view (Descusse & Moog) the inputs of the columns C are delayed through
// integrators until the extended decoupling matrix is regular; the extended relative degrees
// are then the highest derivative of each output the inverse reads, and the integrators their
// sum minus the number of constraints. Both views give the same inverse; this one needs no
// extra states. The crane: tension (hoist W) delayed twice, relative degrees (4, 4).
//
// Rank decisions follow analyze's rule (ClassificationOptions::rank_tolerance): a row of
// u-coefficients a_i, or a singular value of A, counts as zero when at most rank_tolerance
// |grad_x phi| |M^-1 B| at every decision point (the reference state and two generic states),
// so a round-off residue of numeric coefficients never raises or lowers a relative degree.
// A coefficient that vanishes at the reference state only (the crane's y1'' ~ sin(theta)) still
// puts u into that derivative.
#include <ginac/ginac.h>

#include <Eigen/Dense>
#include <cstddef>
#include <string>
#include <vector>

#include "analysis/structure_options.h"
#include "base/errors.h"
#include "modeling/model.h"

namespace servokit {

// GiNaC expressions: hold a SymbolicLock (modeling/symbolic_lock.h) while you keep one.
struct NonlinearStructure {
  std::vector<GiNaC::realsymbol> parameters, coordinates, velocities;
  // Y_ik = y_i_d^(k), named "y<i+1>_d" and k primes, k = 0..highest_derivative[i].
  std::vector<std::vector<GiNaC::realsymbol>> output_derivatives;
  // The u-free constraints c(q, q', Y) = 0, each with the output (row) it came from and its
  // derivative order.
  std::vector<GiNaC::ex> constraints;
  std::vector<std::size_t> constraint_row;
  std::vector<int> constraint_order;
  // The m input equations 0 = input_drift[i] + sum_k input_coefficients[i][k] u_k.
  std::vector<GiNaC::ex> input_drift;
  std::vector<std::vector<GiNaC::ex>> input_coefficients;
  // Per output: the first derivative in which u appears (the nonlinear relative degree).
  std::vector<int> relative_degree;
  // Per output: the highest derivative of y_d the inverse reads (the relative degrees after
  // the dynamic extension; equal to relative_degree when no step was needed).
  std::vector<int> highest_derivative;
  std::vector<StructureStep> extension_steps;  // empty when A was regular at once
  // The rank of the final coefficient matrix at the reference state (m when it is regular
  // there, less when it is singular at the reference only: the relative degree is then not
  // defined there, e.g. a crane with a fixed rope observed at its load).
  std::size_t reference_rank = 0;
  // Parameters whose nominal value the derivation relies on: substituted because they are 0,
  // or in a coefficient dropped as zero.
  std::vector<std::size_t> pinned_parameters;

  bool extended() const { return !extension_steps.empty(); }
  // Integrators of the dynamic extension: sum(highest_derivative) - constraints.
  int integrators() const;
  // 2 dof - constraints: the order of the internal dynamics (0: flat).
  std::size_t internal_order() const { return 2 * coordinates.size() - constraints.size(); }
  // [parameters, q, q', Y] in the order the compiled programs read them.
  std::vector<GiNaC::ex> ProgramInputs() const;
};

/// What `analyze` reports of the structure algorithm.
struct NonlinearStructureSummary {
  bool derived = false;  // false: `note` says why the algorithm stopped
  // Which route decided (or stopped): kNumericRoute, on the compiled programs, or
  // kSymbolicRoute, GiNaC's (a dynamic extension the numeric route does not take).
  std::string route;
  std::vector<int> relative_degree;
  bool extended = false;
  std::vector<std::string> delayed_inputs;  // names, over all steps
  int integrators = 0;
  std::vector<int> extended_relative_degree;
  std::size_t internal_order = 0;
  bool defined_at_operating_point = false;
  std::string note;
};

inline constexpr const char* kNumericRoute = "numeric";
inline constexpr const char* kSymbolicRoute = "symbolic";

/// Runs the structure algorithm and summarizes it; a NoSolution of the algorithm becomes the
/// note of a summary that is not derived. The numeric route (analysis/numeric_structure.h)
/// decides first, with no formula; only when the inputs' coefficient matrix is singular nearby
/// (a dynamic extension) does the symbolic route derive the combined rows. Thread-safe: the
/// symbolic work runs under SymbolicLock (modeling/symbolic_lock.h), one caller after the other.
NonlinearStructureSummary SummarizeNonlinearStructure(const Model& model,
                                                      const NonlinearStructureOptions& options);

/// Runs the structure algorithm. Throws NoSolution naming the output or the reason when an
/// output never depends on the inputs within 2 dof derivatives, when the outputs would need
/// more than 2 dof constraints (they are not independent: no left inverse), or when the
/// coefficient matrix has a lower rank at the reference state than on its neighbourhood (the
/// rows to keep are not defined there). Runs under SymbolicLock (modeling/symbolic_lock.h); the
/// caller holds one too for as long as it keeps the result, whose expressions are GiNaC's.
NonlinearStructure DeriveNonlinearStructure(const Model& model,
                                            const NonlinearStructureOptions& options = {});

}  // namespace servokit
