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
// a summary needs when A is regular nearby. When A is singular nearby, the rows a dynamic
// extension combines are functions of the state, not numbers; the symbolic route derives them.
#include <cstddef>
#include <vector>

#include "analysis/structure_options.h"
#include "modeling/model.h"

namespace servokit {

/// What the numeric route decides.
struct NumericStructure {
  /// Per output: the first derivative in which u appears.
  std::vector<int> relative_degree;
  /// The rank of A (the rows of u-coefficients at the relative degrees) on a neighbourhood
  /// (the largest at the generic decision points) and at the reference state.
  std::size_t rank_nearby = 0;
  std::size_t reference_rank = 0;
};

/// Runs the first pass of the structure algorithm numerically. Throws NoSolution with the
/// symbolic route's message when an output never depends on the inputs within 2 dof
/// derivatives or the outputs need more than 2 dof constraints. Thread-safe: no GiNaC.
NumericStructure DeriveNumericStructure(const Model& model,
                                        const NonlinearStructureOptions& options);

}  // namespace servokit
