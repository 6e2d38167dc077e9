// The time derivative along the velocities (modeling/time_derivative.h) against its definition
// written with GiNaC's own diff, D e = sum_k de/dq_k q'_k: equal once both are expanded, for
// every kind of node a model holds (sums, products, powers with constant and varying
// exponents, functions of one and two arguments, shared subexpressions), and zero for what
// does not move (parameters, the velocities themselves: the accelerations are not part of D).
// The same class seeded {q_k: 1} is GiNaC's diff by q_k on the same expressions.
#include "modeling/time_derivative.h"

#include <catch2/catch.hpp>
#include <vector>

#include "modeling/symbolic_lock.h"

namespace servokit::detail {
namespace {

GiNaC::ex ByDefinition(const GiNaC::ex& e,
                       const std::vector<GiNaC::realsymbol>& coordinates,
                       const std::vector<GiNaC::realsymbol>& velocities) {
  GiNaC::ex rate = 0;
  for (std::size_t k = 0; k < coordinates.size(); ++k) {
    rate += e.diff(coordinates[k]) * velocities[k];
  }
  return rate;
}

}  // namespace

TEST_CASE("D e is sum_k de/dq_k q'_k for every kind of node", "[modeling][time_derivative]") {
  const SymbolicLock lock;
  const GiNaC::realsymbol q1("q1"), q2("q2"), v1("q1_dot"), v2("q2_dot"), l("l"), m("m");
  const std::vector<GiNaC::realsymbol> coordinates = {q1, q2}, velocities = {v1, v2};
  const GiNaC::ex closure = GiNaC::sqrt(GiNaC::pow(l - GiNaC::sin(q1), 2) + GiNaC::cos(q2));
  const std::vector<GiNaC::ex> expressions = {
      q1,
      m * q1 * q2 * v1,
      GiNaC::pow(q1 + 2 * q2, 3) * v2,
      GiNaC::pow(q1, q2) + GiNaC::pow(l, q1 * q2),
      GiNaC::sin(q1 + q2) * GiNaC::cos(q1 - q2) + GiNaC::tan(q1) / GiNaC::exp(q2),
      GiNaC::atan2(l * GiNaC::sin(q1), q2 + l) * v1 * v2,
      GiNaC::log(1 + q1 * q1) + GiNaC::abs(q1 - l) + GiNaC::asin(q2 / 3) + GiNaC::tanh(q1),
      closure * GiNaC::atan2(closure, q1) + 1 / closure,  // shared subexpressions
  };
  for (const GiNaC::ex& e : expressions) {
    INFO(e);
    TimeDerivative rate(coordinates, velocities);
    const GiNaC::ex difference = (rate(e) - ByDefinition(e, coordinates, velocities)).expand();
    CHECK(GiNaC::normal(difference).is_zero());
    // The seed {q_k: 1} is d/dq_k (the projected equations' Jacobians), one memo for all e.
    for (const GiNaC::realsymbol& coordinate : coordinates) {
      DirectionalDerivative partial({{coordinate, 1}});
      CHECK(GiNaC::normal((partial(e) - e.diff(coordinate)).expand()).is_zero());
    }
  }
}

TEST_CASE("D of parameters and velocities is zero", "[modeling][time_derivative]") {
  const SymbolicLock lock;
  const GiNaC::realsymbol q("q"), v("q_dot"), c("c");
  TimeDerivative rate({q}, {v});
  CHECK(rate(c * GiNaC::sin(c)).is_zero());
  CHECK(rate(v * v).is_zero());
  CHECK(rate(GiNaC::numeric(3, 2)).is_zero());
  CHECK(rate(GiNaC::Pi * q).is_equal(GiNaC::Pi * v));
  CHECK((rate(q * v) - v * v).is_zero());
}

}  // namespace servokit::detail
