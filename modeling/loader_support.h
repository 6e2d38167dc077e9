#pragma once
// What the model-file reader shares between the two kinds (modeling/loaded_model.cpp reads and
// parses the file once and dispatches on `kind`; modeling/model_loader.cpp builds multibody
// models, modeling/linear_model.cpp `kind: linear`): reading and parsing the file, the expression
// language of docs/model-files.md ("The explicit form"), the checks that keep GiNaC's parser from
// reading a mistake as something else, names, and the content hash that sweep.json records.
// Internal to modeling/ (namespace detail).
#include <ginac/ginac.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "modeling/canonical_expression.h"
#include "modeling/model.h"

namespace servokit::detail {

/// The `kind` key of a model file and its values (modeling/loaded_model.h).
inline constexpr std::string_view kKindKey = "kind";
inline constexpr std::string_view kMultibodyKind = "multibody";
inline constexpr std::string_view kLinearKind = "linear";
/// Multibody models written as energies (modeling/lagrangian_model.h) or as planar rigid bodies
/// (modeling/planar_bodies.h) instead of M(q) and f(q, q'); loaded into the same Model.
inline constexpr std::string_view kLagrangianKind = "lagrangian";
inline constexpr std::string_view kPlanarBodiesKind = "planar-bodies";

/// A model file read and parsed once: where it came from (the path as given, or the name given
/// with YAML text; messages start with it), its bytes (for the content hash) and its YAML tree.
struct ModelDocument {
  std::string source;
  std::string text;
  YAML::Node root;
};

/// Parses `yaml_text`. Throws ModelError "source:line:column: bad YAML: ..." (counted from 1).
ModelDocument ParseModelDocument(std::string yaml_text, std::string source);
/// Reads and parses the file at `path`. Throws ModelError "path: cannot read the model file
/// (reason)" when it cannot be read, and as ParseModelDocument.
ModelDocument ReadModelDocument(const std::string& path);

/// The reader of multibody models, from a parsed document of that kind (modeling/model_loader.cpp;
/// that of linear models is BuildLinearModel, modeling/linear_model.h). Throws as LoadModel does.
Model BuildModel(const ModelDocument& document, const std::vector<ParameterOverride>& overrides);

/// docs/model-files.md, "The explicit form": the functions an expression may call.
inline constexpr std::array<std::string_view, 14> kModelFunctions = {
    "sin", "cos", "tan",  "asin", "acos", "atan", "atan2",
    "exp", "log", "sqrt", "sinh", "cosh", "tanh", "abs"};
/// How many arguments a function of kModelFunctions takes: 2 for atan2, else 1.
constexpr std::size_t FunctionArity(std::string_view function) {
  return function == "atan2" ? 2 : 1;
}
/// GiNaC's parser recurses per level of parentheses and per power in a chain (a^b^c), and a
/// model file's line can be long enough to overflow the stack; these bound each, far above what
/// a model needs.
inline constexpr std::size_t kMaxParenthesisDepth = 100;
inline constexpr std::size_t kMaxChainedPowers = 10;
/// Largest |exponent| a constant exponent may have, and most decimal digits a number computed
/// from numbers only may have: GiNaC computes number^number exactly while it parses.
inline constexpr double kMaxConstantExponent = 1000;
inline constexpr double kMaxConstantDigits = 10000;
/// The name of the constant pi in expressions.
inline constexpr std::string_view kPiName = "pi";
/// GiNaC's parser reads these as its own constants before it looks at the symbol table, so a
/// parameter with one of these names would silently be replaced.
inline constexpr std::array<std::string_view, 4> kParserLiterals = {"I", "Pi", "Euler", "Catalan"};

/// How a number may be written, for messages about values.
inline constexpr std::string_view kQuantityHint = "(use e.g. 5 or \"5 deg\")";

/// FNV-1a, 64 bit, over any number of byte ranges (the model file, then its matrix files).
class ContentHasher {
 public:
  void Add(std::string_view bytes);
  /// The hash as 16 lower-case hex digits.
  std::string Hex() const;

 private:
  std::uint64_t hash_ = 14695981039346656037ull;  // FNV offset basis
};

/// "a, b, c".
template <typename Strings>
std::string Join(const Strings& strings) {
  std::string joined;
  for (const auto& text : strings) {
    if (!joined.empty()) joined += ", ";
    joined += text;
  }
  return joined;
}

template <typename Strings>
bool Contains(const Strings& strings, std::string_view text) {
  return std::find(strings.begin(), strings.end(), text) != strings.end();
}

bool IsIdentifierStart(char c);  // a letter
bool IsIdentifierChar(char c);   // a letter, a digit or '_'
/// Names GiNaC's parser reads as one identifier: a letter, then letters, digits and '_'.
bool IsIdentifier(std::string_view name);

/// Why `name` cannot name a parameter, coordinate or input (not an identifier, a function's
/// name, pi or one of GiNaC's constants), or nullopt.
std::optional<std::string> ReservedNameProblem(const std::string& name);

// What is wrong with a model's free text (its name, its description), or nothing: a control
// character (a line break, a tab, ESC, DEL, NUL) would end a line of a gnuplot script, a
// Modelica comment or a terminal's text early. A description may hold line breaks and tabs
// (YAML's folded and literal blocks make them); a name may not.
std::optional<std::string> FreeTextProblem(std::string_view text, bool line_breaks_allowed);

/// "key[i]".
std::string Indexed(std::string_view key, std::size_t i);

/// The first of `symbols` that `expression` holds, or nullptr. One walk: GiNaC's has() walks the
/// tree once per symbol asked for and matches a pattern at every node, dof times a chain's
/// positions, which hold n^2 nodes each (issue #31).
const GiNaC::realsymbol* FirstSymbolIn(const GiNaC::ex& expression,
                                       const std::vector<GiNaC::realsymbol>& symbols);

/// `text` as an error message quotes it: whole up to 200 bytes, else its first 160 (not cutting a
/// UTF-8 character) and its length, so that the one-line message of a 10^5-term expression
/// stays one line.
std::string Excerpt(const std::string& text);

/// The expression as GiNaC prints it.
std::string Text(const GiNaC::ex& expression);

/// What a name in an expression is checked with: `called` when '(' follows it.
using NameCheck = std::function<std::optional<std::string>(const std::string& name, bool called)>;

/// Scans `text` as the expression language and returns the first problem, or nullopt: a
/// malformed number ("2x", "1.2.3"), a character that is no operator, what `check_name` says of
/// a name, unbalanced or empty parentheses, a function with the wrong number of arguments, a
/// sign after an operator (which GiNaC reads differently from everyone else: 2*-x+1 is
/// 2*(1-x) to it), more parentheses or chained powers than the limits above, or a constant
/// exponent or a number computed from numbers beyond kMaxConstantExponent and
/// kMaxConstantDigits. Catches what GiNaC's parser would report less clearly, read as
/// something else, or crash on (issue #7's fuzzing: "cos()").
std::optional<std::string> FindLexicalProblem(const std::string& text, const NameCheck& check_name);

/// The first construct an expression read by ExpressionParser (in `canonical`) may not contain,
/// or nullopt, in canonical order. The reader only builds what docs/model-files.md allows from
/// the names it is given, but GiNaC evaluates what the reader hands it: sqrt(-1) becomes I and
/// 1e400 a float no double holds.
std::optional<std::string> FindUnsupported(const CanonicalExpressions& canonical,
                                           const CanonicalExpressions::Scaled& value);

/// Applies the parameter overrides to `parameters` (in the order of `parameter_names`). Throws
/// ParameterOverrideError for an unknown name (listing the known ones) or a value that is not a
/// number (optionally with "deg"). An override in degrees marks its parameter kDegree in `units`
/// (same order); one without leaves the parameter's unit as it was.
void ApplyParameterOverrides(const std::vector<std::string>& parameter_names,
                             const std::vector<ParameterOverride>& overrides,
                             Eigen::VectorXd& parameters,
                             std::vector<DisplayUnit>& units);

}  // namespace servokit::detail
