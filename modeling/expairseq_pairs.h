#pragma once
// The operands of a GiNaC sum or product as GiNaC stores them, without rebuilding them.
//
// GiNaC keeps a sum's terms and a product's factors as pairs (rest, coefficient): coefficient *
// rest in a sum, rest ^ coefficient in a product, beside an overall number. op(i) hands each out
// recombined: a new product or power, built and evaluated on every call, which whoever walks
// the expression takes apart again. For a sum of 10^5 terms that was a tenth of compiling it
// (issue #31). The pairs are protected members of GiNaC::expairseq, meant for its subclasses;
// this subclass only reads them, and is never instantiated. Internal to modeling/; hold a
// SymbolicLock (modeling/symbolic_lock.h).
#include <ginac/ginac.h>

namespace servokit::detail {

class ExpairseqPairs : public GiNaC::expairseq {
 public:
  ExpairseqPairs() = delete;

  /// The pairs of a sum or product, in GiNaC's order (which follows addresses: sort what
  /// reaches a result).
  static const GiNaC::epvector& Of(const GiNaC::expairseq& sequence) {
    return sequence.*(&ExpairseqPairs::seq);
  }
  /// The overall number: a sum's constant term (0 when none), a product's factor (1 when none).
  static const GiNaC::numeric& OverallCoefficient(const GiNaC::expairseq& sequence) {
    return GiNaC::ex_to<GiNaC::numeric>(sequence.*(&ExpairseqPairs::overall_coeff));
  }
};

}  // namespace servokit::detail
