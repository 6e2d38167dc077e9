#pragma once
// The time derivative of an expression along a motion's velocities with its accelerations held
// at zero: D e = sum_k de/dq_k q'_k, where e may hold q, q' and parameters. Lagrange's equations
// need it for (d2T/dq' dq) q' = D(dT/dq') and the bodies' kinetics for velocities and
// convective accelerations (D r, D D r).
//
// GiNaC's diff differentiates by one symbol and walks the whole tree each time, so D by dof
// calls costs dof times the expression, and an expression built from shared subexpressions (a
// loop closure's atan2 inside every coordinate of a linkage) is walked once per occurrence. D
// here is one walk with each distinct subexpression differentiated once (memoized by structure),
// the symbolic forward mode: its cost grows with the expression's DAG, not with the product of
// its size and the coordinates (issue #31). Each rule builds the product GiNaC's diff builds, so
// that the expanded result is the same expression as sum_k diff(e, q_k) q'_k expanded.
//
// Internal to modeling/ (namespace detail); runs under the loader's SymbolicLock.
#include <ginac/ginac.h>

#include <unordered_map>
#include <utility>
#include <vector>

namespace servokit::detail {

/// The sum of `terms` built at once (repeated += would merge k terms k times); 0 for none.
GiNaC::ex SumOf(GiNaC::exvector terms);

/// d expression / d symbol, as expression.diff(symbol), but a product differentiates only the
/// factors that contain the symbol: GiNaC's mul::derivative builds and evaluates one product
/// per factor, most of them zero (a term of T has six factors and two velocities; issue #31).
GiNaC::ex PartialDerivative(const GiNaC::ex& expression, const GiNaC::symbol& symbol);

/// A derivative by the chain rule with given seeds: D s = seed of s for each seeded symbol, 0 for
/// every other symbol. The seed {x: 1} is d/dx; TimeDerivative's are the velocities. Memoized
/// by structure, so an expression built from shared (or equal) subexpressions costs its DAG.
class DirectionalDerivative {
 public:
  explicit DirectionalDerivative(const std::vector<std::pair<GiNaC::ex, GiNaC::ex>>& seeds);

  /// D e. Throws std::invalid_argument for what has no derivative (a relation, a matrix).
  GiNaC::ex operator()(const GiNaC::ex& expression);

 private:
  GiNaC::ex Derive(const GiNaC::ex& expression);
  GiNaC::ex DeriveProduct(const GiNaC::ex& product);
  GiNaC::ex DerivePower(const GiNaC::ex& power);
  GiNaC::ex DeriveFunction(const GiNaC::ex& function);

  // Known: seeds and results; by GiNaC's hash, never iterated.
  std::unordered_map<GiNaC::ex, GiNaC::ex, std::hash<GiNaC::ex>, GiNaC::ex_is_equal> rates_;
  GiNaC::realsymbol argument_;  // stands for a function's argument while it is differentiated
};

class TimeDerivative : public DirectionalDerivative {
 public:
  /// `velocities[k]` is the rate of `coordinates[k]`; every other symbol is constant.
  TimeDerivative(const std::vector<GiNaC::realsymbol>& coordinates,
                 const std::vector<GiNaC::realsymbol>& velocities);
};

}  // namespace servokit::detail
