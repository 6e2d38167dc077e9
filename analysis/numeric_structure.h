#pragma once
// The structure algorithm (analysis/nonlinear_structure.h) evaluated numerically: the
// derivatives of the outputs along motions (modeling/motion_series.h) at the same decision points
// and with the same rank rule, without a formula (issue #31). Each output is differentiated until
// the inputs appear; the u-coefficients of y_i^(k) are its derivatives along each input, and
// |grad phi| of the rule its derivatives along each state coordinate, all carried exactly by the
// motions' dual numbers (no difference of two motions, whose rounding would grow with a drift
// that dwarfs the inputs' part).
//
// It decides the relative degrees and the rank of the inputs' coefficient matrix A, which is all
// a summary needs when A is regular nearby. When A is singular nearby it takes one step of the
// dynamic extension as the symbolic route does: the rows R kept, every other row d replaced by
//   g_d = y_d^(r_d) - y_d_d^(r_d) - kappa(q, q') (y_R^(r_R) - y_R_d^(r_R)),  kappa = A_dC A_RC^-1,
// free of u. kappa is a function of the state, but g_d needs no formula for it: along the
// motion whose inputs C make the kept outputs follow y_R_d (a tracking motion,
// modeling/motion_series.h) the bracket vanishes, so g_d's derivatives are y_d's there, and
// their u-coefficients are grad_q' g_d^(k) M^-1 B, as the symbolic route's. That needs the kept
// rows at relative degree 2 (P_RC = H_R M^-1 B_C regular) and one step; otherwise (a second
// step, a kept row of higher degree) the symbolic route derives the extension.
#include <cstddef>
#include <optional>
#include <vector>

#include "analysis/structure_options.h"
#include "modeling/model.h"

namespace servokit {

/// One step of the dynamic extension, derived numerically.
struct NumericExtension {
  StructureStep step;
  /// Per output: the order of its input equation after the step (the kept rows' relative
  /// degree, the combined rows' first derivative of g_d in which u appears).
  std::vector<int> final_order;
  /// Per output: the highest derivative of y_d the inverse reads (the extended relative degree).
  std::vector<int> highest_derivative;
  /// The u-free constraints: sum of final_order.
  std::size_t constraints = 0;
  /// The rank of the final coefficient matrix at the reference state.
  std::size_t reference_rank = 0;
};

/// What the numeric route decides.
struct NumericStructure {
  /// Per output: the first derivative in which u appears.
  std::vector<int> relative_degree;
  /// The rank of A (the rows of u-coefficients at the relative degrees) on a neighbourhood
  /// (the largest at the generic decision points) and at the reference state.
  std::size_t rank_nearby = 0;
  std::size_t reference_rank = 0;
  /// When rank_nearby < m: the dynamic extension, when one step of the numeric route derives it
  /// (nullopt: the symbolic route must).
  std::optional<NumericExtension> extension;
};

/// Runs the structure algorithm numerically. Throws NoSolution with the symbolic route's message
/// when an output never depends on the inputs within 2 dof derivatives, the outputs need more
/// than 2 dof constraints, or the rows to keep are not defined at the reference state
/// (UndefinedRelativeDegree). Thread-safe: no GiNaC.
NumericStructure DeriveNumericStructure(const Model& model,
                                        const NonlinearStructureOptions& options);

}  // namespace servokit
