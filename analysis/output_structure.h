#pragma once
// Relative degrees, the structure at infinity, the differentiation index and the order of the
// internal dynamics of the linearization, all from one subspace iteration, so that they cannot
// contradict each other.
//
// The iteration (Wonham's V* algorithm; Isidori 1995, Sect. 5.1 for the nonlinear version):
//   V_0 = state space,  V_{k+1} = ker C  intersected with  A^-1 (V_k + im B).
// V_k are the states from which the output can be kept at zero for k derivatives; the limit V*
// is the tangent space of the zero-dynamics manifold, so dim V* is the order of the internal
// dynamics. d_k = dim V_k - dim V_{k+1} counts the infinite zeros of order > k, which gives the
// structure at infinity {sigma_i}: for a single output sigma = r, the relative degree.
// The highest derivative of y_d that u_d needs is sigma_max, so the index of the DAE (8)-(9) is
// sigma_max + 1 (Campbell 1995; paper Sect. 3: 3, 3, 4, 5 for the four mass-on-car cases), and
// the projected DAE (15)-(18), which carries the constraint at acceleration level, has index
// sigma_max - 1 (paper Sect. 2.3: "index reduction by two").
// With every relative degree 2 and P regular (orthogonal realizations) V* is known without
// iterating: {dq in ker H, dq' in ker H}, every infinite zero of order 2 (paper Eq. 25).
// More generally, with a regular decoupling matrix V* is the kernel of the rows C_i A^k,
// k < r_i, and the infinite zeros have the orders r_i: no iteration either (the six-mass chain
// and the gantry crane, both flat, need none of the iteration's SVDs).
#include <Eigen/Dense>
#include <vector>

#include "analysis/linearization.h"
#include "analysis/options.h"

namespace servokit {

struct OutputStructure {
  // Per output: the least r with C_i A^(r-1) B != 0 (the first derivative of y_i that u enters).
  std::vector<int> relative_degree;
  // The orders of the infinite zeros, ascending (one per output). Equal to relative_degree,
  // sorted, when the decoupling matrix is regular; otherwise they describe what the inverse
  // needs (MIMO with a singular decoupling matrix: no vector relative degree exists).
  std::vector<int> infinite_zero_orders;
  // Rows C_i A^(r_i - 1) B, outputs x inputs; regular = the vector relative degree exists.
  Eigen::MatrixXd decoupling_matrix;
  bool decoupling_matrix_regular = false;
  int differentiation_index = 0;    // of the DAE (8)-(9): sigma_max + 1
  int projected_index = 0;          // of the projected DAE (15)-(18): sigma_max - 1
  int internal_dynamics_order = 0;  // dim V*, first-order dimension of the internal dynamics
  // Orthonormal basis of V* in the coordinates of `state_space` (2 dof x internal order).
  Eigen::MatrixXd zero_dynamics_subspace;
  // The first-order form used (balanced; see ToStateSpace).
  StateSpace state_space;
};

/// How V* is found when the decoupling matrix is regular: kDirect (the default) as the kernel of
/// the rows C_i A^k, k < r_i (the V* iteration only where the numbers do not bear out the
/// theory, inside the tolerance band of a singular point); kIteration always iterates (tests
/// compare the two).
enum class StructureRoute { kDirect, kIteration };

/// Analyses the linearization. Throws NoSolution when the inputs do not determine the output
/// (an output with infinite relative degree) or the output does not determine the inputs (the
/// system is not left-invertible), since then the servo-constraint problem has no unique solution.
OutputStructure AnalyzeOutputStructure(const Linearization& linearization,
                                       const ClassificationOptions& options,
                                       StructureRoute route = StructureRoute::kDirect);

}  // namespace servokit
