#pragma once
// servokit's reader of the expression language of model files (docs/model-files.md): text
// straight to the canonical form of modeling/canonical_expression.h.
//
// GiNaC's parser builds and evaluates a GiNaC object for every operation, and servokit then
// converted the result once more into its canonical form: for a force of 10^5 terms that was
// most of loading the model (issue #31). This reader builds sums, numbers and products of
// powers of symbols (the bulk of a large polynomial or of expanded equations of motion) in the
// canonical form directly, by the rules GiNaC's evaluation applies to them
// (CanonicalExpressions::Sum, Monomial). Every other operation (functions, a product with a sum
// or a function in it, fractional or symbolic powers) it hands to GiNaC on GiNaC expressions of
// its operands, and converts the result: so it evaluates those exactly as GiNaC does, and it
// throws what GiNaC throws for them (1/0, log(0)). A test holds the result equal to the
// canonical form of GiNaC's own parse for every expression of the shipped and test models
// (tests/modeling/expression_parser_test.cpp).
//
// The text must have passed FindLexicalProblem (modeling/loader_support.h), which bounds its
// nesting and rejects what GiNaC would misread. Hold a SymbolicLock (modeling/symbolic_lock.h).
#include <ginac/ginac.h>

#include <string>

#include "modeling/canonical_expression.h"

namespace servokit {

class ExpressionParser {
 public:
  /// Reads into `canonical`, looking names up in `names` (parameters, coordinates, velocities
  /// and Pi, as GiNaC's parser would). Both must outlive the parser.
  ExpressionParser(CanonicalExpressions& canonical, const GiNaC::symtab& names)
      : canonical_(canonical), names_(names) {}

  /// The canonical form of `text`. Throws GiNaC::parse_error, with GiNaC's parser's own message,
  /// for text that does not parse, and what GiNaC throws for an operation it refuses.
  CanonicalExpressions::Scaled Parse(const std::string& text);

 private:
  CanonicalExpressions& canonical_;
  const GiNaC::symtab& names_;
};

}  // namespace servokit
