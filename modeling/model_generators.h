#pragma once
// Generators of large linear models (issue #6, `servokit generate`): the files a user would
// otherwise write by hand for a lumped chain or a finite-element flexible link.
#include <optional>
#include <string_view>

#include "base/vocabulary.h"
#include "modeling/linear_model.h"

namespace servokit {

/// A chain of N equal masses m: the ground, a spring k with a damper d in parallel, mass 1,
/// spring and damper, mass 2, ..., mass N (free end). A force on `input_mass` is the input; the
/// position of `output_mass` is the output (both 1-based), or a weighted sum of every mass's
/// position (`output_weights`: an output that mixes all N coordinates, a dense row of C).
/// Coordinates: the mass positions.
/// M = m I; K = k T and D = d T with T the tridiagonal fixed-free Laplacian
/// (2 on the diagonal except 1 at (N, N), -1 beside it). Written with parameters m, k, d so
/// that sweeps can vary them (M = m * unit, K = k * T, D = d * T).
struct ChainOptions {
  long masses = 1000;      // N >= 1
  double mass = 1.0;       // kg
  double stiffness = 1.0;  // N/m
  double damping = 0.01;   // N s/m
  long input_mass = 1;     // 1..N
  long output_mass = 1;    // 1..N; must stay 1 unless output_weights is kMass
  ChainOutputWeights output_weights = ChainOutputWeights::kMass;
  /// Close the chain into a ring: mass N joined rigidly back to mass 1, the loop constraint
  /// G q = q_N - q_1 = 0 (a closed chain, the file's constraint_matrix; at least 3 masses).
  /// Named ring_N instead of chain_N.
  bool closed = false;
  /// Throws OptionError (a UsageError) naming the field, its value and the rule.
  void Validate() const;
};
LinearModelFiles GenerateChain(const ChainOptions& options);

/// A flexible link on an actuated hub (the non-minimum-phase flexible manipulator): a rigid hub
/// of inertia J turning by the angle theta under the torque u, and an Euler-Bernoulli beam of
/// length L, mass per length rho_a and bending stiffness EI, clamped to the hub, in the hub's
/// rotating frame, linearised about rest (no centrifugal stiffening), cut into N equal Hermite
/// cubic elements. Coordinates: theta, then (w_i, w_i') at nodes 1..N (w: deflection
/// perpendicular to the undeformed link). Output: the tip's inertial displacement
/// y = L theta + w_N. M is the consistent mass matrix including the hub-beam coupling
/// (integral of rho_a x (x theta'' + w'') over the link); K the element stiffness; D = beta K
/// (stiffness-proportional damping). Parameters J, rho_a, EI, beta are written as factors.
struct BeamOptions {
  long elements = 1000;             // N >= 1
  double length = 1.0;              // m
  double hub_inertia = 0.1;         // kg m^2
  double mass_per_length = 1.0;     // kg/m
  double bending_stiffness = 10.0;  // N m^2
  double damping_factor = 1e-4;     // beta in D = beta K, s
  void Validate() const;
};
LinearModelFiles GenerateBeam(const BeamOptions& options);

}  // namespace servokit
