#include "modeling/time_derivative.h"

#include <cassert>
#include <stdexcept>
#include <string>
#include <utility>

namespace servokit::detail {
namespace {

// A product built at once from its factors, as SumOf.
GiNaC::ex Product(GiNaC::exvector factors) {
  return GiNaC::dynallocate<GiNaC::mul>(std::move(factors));
}

}  // namespace

GiNaC::ex SumOf(GiNaC::exvector terms) {
  if (terms.empty()) return 0;
  if (terms.size() == 1) return terms.front();
  return GiNaC::dynallocate<GiNaC::add>(std::move(terms));
}

GiNaC::ex PartialDerivative(const GiNaC::ex& expression, const GiNaC::symbol& symbol) {
  if (!GiNaC::is_a<GiNaC::mul>(expression)) return expression.diff(symbol);
  GiNaC::exvector terms;
  for (std::size_t i = 0; i < expression.nops(); ++i) {
    const GiNaC::ex& factor = expression.op(i);
    if (!factor.has(symbol)) continue;
    GiNaC::exvector factors;
    factors.reserve(expression.nops());
    for (std::size_t j = 0; j < expression.nops(); ++j) {
      factors.push_back(j == i ? factor.diff(symbol) : expression.op(j));
    }
    terms.push_back(Product(std::move(factors)));
  }
  return SumOf(std::move(terms));
}

DirectionalDerivative::DirectionalDerivative(
    const std::vector<std::pair<GiNaC::ex, GiNaC::ex>>& seeds)
    : argument_("time_derivative_argument") {
  for (const auto& [symbol, rate] : seeds) {
    assert(GiNaC::is_a<GiNaC::symbol>(symbol));
    rates_.emplace(symbol, rate);
  }
}

GiNaC::ex DirectionalDerivative::operator()(const GiNaC::ex& expression) {
  return Derive(expression);
}

namespace {

// q_k -> q'_k, and q'_k -> 0: the accelerations are not part of D.
std::vector<std::pair<GiNaC::ex, GiNaC::ex>> VelocitySeeds(
    const std::vector<GiNaC::realsymbol>& coordinates,
    const std::vector<GiNaC::realsymbol>& velocities) {
  assert(coordinates.size() == velocities.size());
  std::vector<std::pair<GiNaC::ex, GiNaC::ex>> seeds;
  for (std::size_t k = 0; k < coordinates.size(); ++k) {
    seeds.emplace_back(coordinates[k], velocities[k]);
    seeds.emplace_back(velocities[k], 0);
  }
  return seeds;
}

}  // namespace

TimeDerivative::TimeDerivative(const std::vector<GiNaC::realsymbol>& coordinates,
                               const std::vector<GiNaC::realsymbol>& velocities)
    : DirectionalDerivative(VelocitySeeds(coordinates, velocities)) {}

GiNaC::ex DirectionalDerivative::Derive(const GiNaC::ex& expression) {
  if (const auto found = rates_.find(expression); found != rates_.end()) return found->second;
  GiNaC::ex rate;
  if (GiNaC::is_a<GiNaC::add>(expression)) {
    GiNaC::exvector terms;
    for (const GiNaC::ex& term : expression) {
      GiNaC::ex term_rate = Derive(term);
      if (!term_rate.is_zero()) terms.push_back(std::move(term_rate));
    }
    rate = SumOf(std::move(terms));
  } else if (GiNaC::is_a<GiNaC::mul>(expression)) {
    rate = DeriveProduct(expression);
  } else if (GiNaC::is_a<GiNaC::power>(expression)) {
    rate = DerivePower(expression);
  } else if (GiNaC::is_a<GiNaC::function>(expression)) {
    rate = DeriveFunction(expression);
  } else if (GiNaC::is_a<GiNaC::numeric>(expression) || GiNaC::is_a<GiNaC::symbol>(expression) ||
             GiNaC::is_a<GiNaC::constant>(expression)) {
    rate = 0;  // a number, a parameter or a constant: the seeds name every symbol that moves
  } else {
    throw std::invalid_argument("cannot take the time derivative of " +
                                std::string(GiNaC::ex_to<GiNaC::basic>(expression).class_name()));
  }
  rates_.emplace(expression, rate);
  return rate;
}

// sum_i D(a_i) prod_(j != i) a_j, as GiNaC's mul::derivative.
GiNaC::ex DirectionalDerivative::DeriveProduct(const GiNaC::ex& product) {
  GiNaC::exvector terms;
  for (std::size_t i = 0; i < product.nops(); ++i) {
    GiNaC::ex factor_rate = Derive(product.op(i));
    if (factor_rate.is_zero()) continue;
    GiNaC::exvector factors;
    factors.reserve(product.nops());
    for (std::size_t j = 0; j < product.nops(); ++j) {
      factors.push_back(j == i ? factor_rate : product.op(j));
    }
    terms.push_back(Product(std::move(factors)));
  }
  return SumOf(std::move(terms));
}

// a^b: b a^(b-1) D(a) for a constant exponent, a^b (D(b) log a + b D(a) / a) otherwise, as
// GiNaC's power::derivative.
GiNaC::ex DirectionalDerivative::DerivePower(const GiNaC::ex& power) {
  const GiNaC::ex& base = power.op(0);
  const GiNaC::ex& exponent = power.op(1);
  const GiNaC::ex exponent_rate = Derive(exponent);
  if (exponent_rate.is_zero()) {
    return GiNaC::mul(GiNaC::mul(exponent, GiNaC::power(base, exponent + -1)), Derive(base));
  }
  return GiNaC::mul(
      power, GiNaC::add(GiNaC::mul(exponent_rate, GiNaC::log(base)),
                        GiNaC::mul(GiNaC::mul(exponent, Derive(base)), GiNaC::power(base, -1))));
}

// f(a_1..a_m): sum_i (df/da_i)(a) D(a_i), df/da_i by GiNaC's own rule for f, found by
// differentiating f with a symbol in place of a_i.
GiNaC::ex DirectionalDerivative::DeriveFunction(const GiNaC::ex& function) {
  GiNaC::exvector terms;
  for (std::size_t i = 0; i < function.nops(); ++i) {
    GiNaC::ex argument_rate = Derive(function.op(i));
    if (argument_rate.is_zero()) continue;
    GiNaC::exvector arguments(function.begin(), function.end());
    arguments[i] = argument_;
    const GiNaC::ex stand_in =
        GiNaC::function(GiNaC::ex_to<GiNaC::function>(function).get_serial(), arguments);
    const GiNaC::ex partial = stand_in.diff(argument_).subs(argument_ == function.op(i));
    terms.push_back(GiNaC::mul(partial, argument_rate));
  }
  return SumOf(std::move(terms));
}

}  // namespace servokit::detail
