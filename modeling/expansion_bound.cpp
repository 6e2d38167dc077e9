#include "modeling/expansion_bound.h"

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <utility>
#include <vector>

#include "modeling/canonical_expression.h"

namespace servokit {
namespace {

// The terms of a sum of `terms` terms raised to the n-th power: the number of monomials of
// degree n in `terms` variables, C(terms + n - 1, n).
double PowerTerms(double terms, long n) {
  double count = 1.0;
  for (long i = 1; i <= n; ++i) count = count * (terms - 1.0 + double(i)) / double(i);
  return count;
}

// Values computed per node of an expression, found by the node's address (GiNaC shares a
// subexpression's node wherever it was reused, so a walk with it costs the DAG, not the tree).
// Each node is kept alive with its value: the operands of a sum or product are made afresh when
// read (coefficient times rest), and a freed one's address could be another's next.
template <typename Value>
class NodeMemo {
 public:
  const Value* Find(const GiNaC::ex& expression) const {
    const auto found = seen_.find(&GiNaC::ex_to<GiNaC::basic>(expression));
    return found == seen_.end() ? nullptr : &found->second.second;
  }
  void Store(const GiNaC::ex& expression, const Value& value) {
    seen_.emplace(&GiNaC::ex_to<GiNaC::basic>(expression), std::make_pair(expression, value));
  }

 private:
  std::unordered_map<const GiNaC::basic*, std::pair<GiNaC::ex, Value>> seen_;
};

// BoundExpandTerms with a memo of the nodes seen (by address: GiNaC shares a subexpression's
// node wherever it was reused). Returns {terms of the expansion, terms made inside function
// arguments and powers with other exponents}; the second is added for every occurrence, since
// expand() expands a shared argument again wherever it occurs.
class ExpandBound {
 public:
  std::pair<double, double> Of(const GiNaC::ex& expression) {
    if (const auto* known = seen_.Find(expression)) return *known;
    std::pair<double, double> bound{1.0, 0.0};
    if (GiNaC::is_a<GiNaC::add>(expression) || GiNaC::is_a<GiNaC::mul>(expression)) {
      const bool sum = GiNaC::is_a<GiNaC::add>(expression);
      bound.first = sum ? 0.0 : 1.0;
      for (const GiNaC::ex& operand : expression) {
        const auto [terms, inner] = Of(operand);
        bound.first = sum ? bound.first + terms : bound.first * terms;
        bound.second += inner;
      }
    } else if (GiNaC::is_a<GiNaC::power>(expression)) {
      const auto [terms, inner] = Of(expression.op(0));
      const GiNaC::ex& exponent = expression.op(1);
      bound.second = inner + Of(exponent).second;
      if (exponent.info(GiNaC::info_flags::nonnegint)) {
        bound.first = PowerTerms(terms, GiNaC::ex_to<GiNaC::numeric>(exponent).to_long());
      } else {
        bound.second += terms;  // the base is expanded on its own
      }
    } else {
      for (const GiNaC::ex& argument : expression) {
        const auto [terms, inner] = Of(argument);
        bound.second += terms + inner;
      }
    }
    seen_.Store(expression, bound);
    return bound;
  }

 private:
  NodeMemo<std::pair<double, double>> seen_;
};

}  // namespace

double BoundExpandTerms(const GiNaC::ex& expression) {
  const auto [terms, inner] = ExpandBound().Of(expression);
  return terms + inner;
}

GiNaC::ex ExpandWithinBudget(const GiNaC::ex& expression, double max_terms) {
  return BoundExpandTerms(expression) <= max_terms ? expression.expand() : expression;
}

namespace {

// BoundExpandedTerms with a memo of the nodes seen (by address), so that an expression built from
// shared subexpressions (derivatives of derivatives) costs its DAG, not its tree.
class NormalBound {
 public:
  ExpandedTerms Of(const GiNaC::ex& expression) {
    if (const ExpandedTerms* known = seen_.Find(expression)) return *known;
    const ExpandedTerms terms = Compute(expression);
    seen_.Store(expression, terms);
    return terms;
  }

 private:
  ExpandedTerms Compute(const GiNaC::ex& expression) {
    if (GiNaC::is_a<GiNaC::add>(expression)) {
      // Over the common denominator, term i's numerator is multiplied by every other denominator.
      std::vector<ExpandedTerms> operands;
      for (const GiNaC::ex& operand : expression) operands.push_back(Of(operand));
      ExpandedTerms sum{0.0, 1.0};
      for (const ExpandedTerms& operand : operands) sum.denominator *= operand.denominator;
      for (const ExpandedTerms& operand : operands) {
        sum.numerator += operand.numerator * (sum.denominator / operand.denominator);
      }
      return sum;
    }
    if (GiNaC::is_a<GiNaC::mul>(expression)) {
      ExpandedTerms product;
      for (const GiNaC::ex& factor : expression) {
        const ExpandedTerms terms = Of(factor);
        product.numerator *= terms.numerator;
        product.denominator *= terms.denominator;
      }
      return product;
    }
    if (GiNaC::is_a<GiNaC::power>(expression)) {
      const GiNaC::ex exponent = expression.op(1);
      if (GiNaC::is_a<GiNaC::numeric>(exponent) &&
          GiNaC::ex_to<GiNaC::numeric>(exponent).is_integer()) {
        const long n = GiNaC::ex_to<GiNaC::numeric>(exponent).to_long();
        const ExpandedTerms base = Of(expression.op(0));
        const ExpandedTerms raised{PowerTerms(base.numerator, std::labs(n)),
                                   PowerTerms(base.denominator, std::labs(n))};
        return n >= 0 ? raised : ExpandedTerms{raised.denominator, raised.numerator};
      }
    }
    return {};  // a number, a symbol, a function or a power kept whole: one term
  }

  NodeMemo<ExpandedTerms> seen_;
};

}  // namespace

ExpandedTerms BoundExpandedTerms(const GiNaC::ex& expression) {
  return NormalBound().Of(expression);
}

GiNaC::ex NormalWithinBudget(const GiNaC::ex& expression, double max_terms) {
  const ExpandedTerms terms = BoundExpandedTerms(expression);
  return terms.numerator + terms.denominator <= max_terms ? CanonicalNormal(expression)
                                                          : expression;
}

GiNaC::ex LeibnizDeterminant(const GiNaC::matrix& matrix) {
  const unsigned n = matrix.rows();
  assert(matrix.cols() == n && n <= 5);
  std::vector<unsigned> permutation(n);
  std::iota(permutation.begin(), permutation.end(), 0u);
  GiNaC::ex determinant = 0;
  do {
    // The sign of the permutation: the parity of its inversions.
    int inversions = 0;
    for (unsigned i = 0; i < n; ++i) {
      for (unsigned j = i + 1; j < n; ++j) inversions += permutation[i] > permutation[j] ? 1 : 0;
    }
    GiNaC::ex product = inversions % 2 == 0 ? 1 : -1;
    for (unsigned i = 0; i < n; ++i) product *= matrix(i, permutation[i]);
    determinant += product;
  } while (std::next_permutation(permutation.begin(), permutation.end()));
  return determinant;
}

double TreeSize(const GiNaC::ex& expression, double limit) {
  double size = 0.0;
  for (auto node = expression.preorder_begin(); node != expression.preorder_end(); ++node) {
    if (++size > limit) break;
  }
  return size;
}

}  // namespace servokit
