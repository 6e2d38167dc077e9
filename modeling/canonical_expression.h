#pragma once
// Expressions in a form that depends on their mathematics alone, never on memory addresses.
//
// GiNaC keeps the operands of every sum and product sorted by hash values seeded with the
// addresses of its type names. With address-space randomisation these change from run to run,
// and with them the order of the operands and the sign GiNaC gives a sum inside a product (it
// pulls out -1 so that the sum's first operand is positive: (2*l-3*s)*m in one run,
// -(3*s-2*l)*m in the next); normal() and factor() choose signs the same way. Anything that
// walks an expression in GiNaC's order would then differ from run to run: the floating-point
// evaluation order of a compiled program (so its last bits), and printed closed forms.
//
// CanonicalExpressions rebuilds expressions as a DAG in which
//   - every node is a number, a symbol, a constant, a sum, a product, a power or a function;
//   - the operands of sums and products are sorted by a total order of nodes defined by
//     structure alone (kind, names of symbols and functions, values of numbers, operands);
//   - a sum's terms are (coefficient, node) pairs with the first coefficient positive; a sign
//     or a numeric factor is carried outward by the Scaled value that refers to the node;
//   - identical subexpressions are one node (hash-consing), which also shares the
//     subexpressions common to several expressions, whatever sign GiNaC gave them.
// Everything numeric that servokit builds from GiNaC goes through this form (the compiler of
// modeling/expression_program.h), and so does every closed form it prints (CanonicalText).
// GiNaC work: callers hold a SymbolicLock (modeling/symbolic_lock.h) while they use these
// expressions; CanonicalText and CanonicalNormal take one as well.
#include <ginac/ginac.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace servokit {

class CanonicalExpressions {
 public:
  using NodeId = std::uint32_t;

  enum class Kind : std::uint8_t {
    kNumber,    // number: a real or complex GiNaC numeric (1 stands for "no node" in Scaled)
    kConstant,  // name: Pi, Euler, ...
    kSymbol,    // name; symbol: the GiNaC symbol
    kPower,     // operands: {base, exponent}
    kProduct,   // operands: two or more factors, coefficient 1 each, sorted
    kSum,       // operands: two or more terms, sorted, the first coefficient positive
    kFunction,  // name; operands: the arguments in order
    kOpaque,    // anything else GiNaC holds (a list, a relation, a matrix): original only
  };

  /// coefficient * node. A pure number is its value times the node of the number 1.
  struct Scaled {
    GiNaC::numeric coefficient;
    NodeId node;
  };

  struct Node {
    Kind kind;
    std::string name;
    GiNaC::numeric number;
    std::vector<Scaled> operands;
    GiNaC::ex original;       // kSymbol: the symbol; kOpaque: the expression; unused otherwise
    std::size_t ordinal = 0;  // kSymbol: its place in the ordered list (its size if unlisted)
  };

  /// `ordered_symbols` breaks ties between distinct symbols of the same name (their order in
  /// the list); two distinct symbols of one name that are not both in it are a logic error.
  explicit CanonicalExpressions(const std::vector<GiNaC::ex>& ordered_symbols = {});
  // The hash-consing table refers to this object.
  CanonicalExpressions(const CanonicalExpressions&) = delete;
  CanonicalExpressions& operator=(const CanonicalExpressions&) = delete;

  /// The canonical form of `expression` (GiNaC's automatic evaluation having happened).
  Scaled Add(const GiNaC::ex& expression);

  // Building canonical forms without GiNaC (servokit's reader of expressions,
  // modeling/expression_parser.h). Each applies the rules GiNaC's automatic evaluation applies
  // to the same operation, so that the result is what Add() gives for the GiNaC expression; a
  // test holds the two routes equal (tests/modeling/expression_parser_test.cpp).

  /// A number.
  Scaled Number(const GiNaC::numeric& value) const { return {value, one_}; }
  /// The sum of `terms` (GiNaC's add): a term that is a multiple of a sum is replaced by the
  /// multiples of its terms, equal terms are combined and zero terms dropped. A number times a
  /// sum alone is such a sum: GiNaC's mul distributes a number over a single sum.
  Scaled Sum(std::vector<Scaled> terms);
  /// coefficient * prod_k base_k^exponent_k for symbols base_k and integer exponents, and
  /// functions or constants to the power 1, each once (GiNaC's mul of such factors): the
  /// exponents of a base added, zero ones dropped.
  Scaled Monomial(GiNaC::numeric coefficient,
                  std::vector<std::pair<NodeId, GiNaC::numeric>> powers);
  /// Appends the factors of node `id` to `powers` as (base, exponent) pairs, exponents negated
  /// when it `divides`: powers of symbols with integer exponents, and functions and constants to
  /// the power 1, which `atoms` lists too. False when `id` has another factor (`powers` and
  /// `atoms` may then hold some of its factors). A function or constant never divides: GiNaC has
  /// rules for some of their powers (exp(x)^(-1) is exp(-x)), and Monomial takes them once only.
  bool AppendMonomialFactors(NodeId id,
                             bool divides,
                             std::vector<std::pair<NodeId, GiNaC::numeric>>& powers,
                             std::vector<NodeId>& atoms) const;
  /// True when no function or constant of `atoms` (AppendMonomialFactors') occurs twice, so
  /// that Monomial takes them; a function twice is a power of it, for GiNaC's rules
  /// (exp(x)*exp(x) is exp(2*x)). Sorts `atoms`.
  static bool AtomsOnce(std::vector<NodeId>& atoms);
  /// factor * value: the multiple of a sum is the sum of the multiples (GiNaC's mul distributes
  /// a number over a single sum).
  Scaled Scale(const GiNaC::numeric& factor, const Scaled& value);
  /// The function `name` of `arguments` as GiNaC holds it unevaluated. For a caller that knows
  /// GiNaC's evaluation keeps it so: sin, cos, sinh, cosh and exp of arguments that are neither
  /// numbers, constants nor functions (GiNaC's rules for those functions look at nothing else,
  /// not even a sign).
  Scaled HeldFunction(std::string name, std::vector<Scaled> arguments);

  // Multiplying out (GiNaC's expand()), for derivatives that stay polynomials in their atoms
  // (modeling/expanded_derivative.h). "Expanded" is a sum of terms that are each a number times
  // a product of atoms (symbols, constants, functions, with their arguments as they are) and of
  // powers of atoms: the form expand() gives, unique for a value. Each returns nullopt where
  // expand() would do more than multiplying out sums (a quotient by a sum, whose denominator it
  // expands inside the power) or where a product would multiply more than `max_terms` pairs
  // of terms (a product of sums; sums alone grow no faster than their terms).

  /// `value` multiplied out.
  std::optional<Scaled> Expanded(const Scaled& value, double max_terms);
  /// a * b multiplied out, for a and b expanded.
  std::optional<Scaled> ExpandedProduct(const Scaled& a, const Scaled& b, double max_terms);

  /// The number of nodes of `value` as a tree (a shared node counted where it is used, a
  /// coefficient other than 1 as one more), counted up to just past `limit`: about the nodes
  /// GiNaC's walk over the same expression visits (TreeSize, modeling/expansion_bound.h).
  double TreeSize(const Scaled& value, double limit) const;
  /// The GiNaC expression of `value`, built (and so evaluated by GiNaC) from its nodes; each node
  /// is built once. For the operations the builders above do not take.
  GiNaC::ex Expression(const Scaled& value);

  const Node& node(NodeId id) const { return nodes_[id]; }
  NodeId one() const { return one_; }
  /// The total order of nodes: <0, 0 or >0, as a before, equal to or after b.
  int Compare(NodeId a, NodeId b) const;
  /// GiNaC's default syntax for the value (sums and products in canonical order).
  std::string Text(const Scaled& value) const;

 private:
  NodeId Intern(Node node);
  // Builds and remembers a GiNaC expression of `value`'s node from its operands' expressions:
  // a product with `value`'s number, any other node alone.
  void BuildExpression(const Scaled& value);
  // Keeps `expression` as the GiNaC form of `value` for Expression(), unless one is known.
  void Remember(const Scaled& value, const GiNaC::ex& expression);
  Scaled Convert(const GiNaC::ex& expression);
  // A product of atoms and powers of atoms (a term of an expanded sum), or a number.
  bool IsAtomicProduct(NodeId id) const;
  bool IsAtom(NodeId id) const;
  Scaled ConvertSum(const GiNaC::ex& sum);
  Scaled ConvertProduct(const GiNaC::ex& product);
  Scaled ConvertPower(const GiNaC::ex& power);
  Scaled PowerOf(const Scaled& base, const Scaled& exponent);
  NodeId SymbolPower(NodeId base, const GiNaC::numeric& exponent);
  int CompareScaled(const Scaled& a, const Scaled& b) const;
  void Print(const Scaled& value, int context, std::string& out) const;
  void PrintNode(NodeId id, int context, std::string& out) const;
  void PrintPower(const Scaled& base,
                  const GiNaC::numeric& exponent,
                  int context,
                  std::string& out) const;

  // Hash-consing: nodes by their structure (kind, name, symbol, operand ids and
  // coefficients), looked up through their ids.
  struct NodeHash {
    const CanonicalExpressions* self;
    std::size_t operator()(NodeId id) const;
  };
  struct NodeEqual {
    const CanonicalExpressions* self;
    bool operator()(NodeId a, NodeId b) const;
  };
  std::vector<Node> nodes_;
  std::unordered_set<NodeId, NodeHash, NodeEqual> interned_{16, NodeHash{this}, NodeEqual{this}};
  // Expressions already converted, and the listed symbols' ordinals: looked up by GiNaC's hash
  // (cached in each node: an ordered map's compare walked whole trees, issue #31), never
  // iterated, so that their order, which follows addresses, reaches no result.
  std::unordered_map<GiNaC::ex, Scaled, std::hash<GiNaC::ex>, GiNaC::ex_is_equal> converted_;
  std::unordered_map<GiNaC::ex, std::size_t, std::hash<GiNaC::ex>, GiNaC::ex_is_equal>
      symbol_ordinals_;
  std::map<std::string, GiNaC::ex> unlisted_symbols_;       // symbols outside the list, by name
  std::map<std::pair<NodeId, int>, NodeId> symbol_powers_;  // Monomial's powers, interned
  // A GiNaC expression of each node known so far, by NodeId: one that Add() converted, or one
  // Expression() built. It equals coefficient * node, so that a product GiNaC evaluated with
  // its number (2*x*sin(y)) is used again as it is, not built once more.
  struct KnownExpression {
    GiNaC::numeric coefficient;
    GiNaC::ex expression;
  };
  std::vector<std::optional<KnownExpression>> expressions_;
  NodeId one_ = 0;
};

/// Whether forms in a store contain any of some symbols: each node is decided once, however
/// many forms share it (the dof^2 entries of a mass matrix share most of theirs).
class DependenceOn {
 public:
  /// `symbols`: symbol nodes of `canonical`, which must outlive this.
  DependenceOn(const CanonicalExpressions& canonical,
               const std::vector<CanonicalExpressions::NodeId>& symbols);
  /// True when `value` (a form in the store) contains one of the symbols.
  bool operator()(const CanonicalExpressions::Scaled& value);

 private:
  bool Decide(CanonicalExpressions::NodeId id);

  const CanonicalExpressions& canonical_;
  std::vector<signed char> decided_;  // by NodeId: -1 not yet, 0 free of them, 1 contains one
};

/// base^exponent, evaluated by GiNaC. Not GiNaC::pow: that allocates the power on the heap and
/// loses it when evaluating it throws (0^(-1): "division by zero"; found by fuzzing), where a
/// power built here is freed on the way out.
GiNaC::ex EvaluatedPower(const GiNaC::ex& base, const GiNaC::ex& exponent);

/// GiNaC's default text of `expression` (x^2, 1/2*y, sqrt(x), sin(x)...), with the terms of
/// every sum and the factors of every product in the canonical order and sums signed as
/// above, so that the same expression prints the same in every run.
std::string CanonicalText(const GiNaC::ex& expression);

/// GiNaC::normal(expression) with its numerator and its denominator expanded: a form that
/// depends on the rational function alone. normal() alone does not give one: it cancels the
/// same common factors in every run, but it builds the denominator as a product of the
/// cofactors it met while adding the terms in GiNaC's (address-seeded) order, so one run gives
/// (m+mt-m*cos(theta)^2)*cos(theta)^2 and the next (m*cos(theta)^3-(m+mt)*cos(theta))*cos(theta),
/// and a compiled program evaluates them with different rounding. Expanded numerator and
/// denominator are unique up to a common sign, which the canonical form absorbs.
GiNaC::ex CanonicalNormal(const GiNaC::ex& expression);

}  // namespace servokit
