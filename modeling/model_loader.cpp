// LoadModel: model file (docs/model-files.md) -> checked SymbolicModel -> compiled
// programs. M and f come from the file (`mass_matrix`, `forces`) or are derived from energies
// (`kind: lagrangian`) or bodies (`kind: planar-bodies`); from there every form is the same. Every
// problem with the file is one ModelError "file: key[entry]: problem", raised where it is found, so
// that a user sees the first mistake with its place.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "modeling/canonical_expression.h"
#include "modeling/expansion_bound.h"
#include "modeling/expression_parser.h"
#include "modeling/expression_program.h"
#include "modeling/lagrangian_model.h"
#include "modeling/loader_support.h"
#include "modeling/model.h"
#include "modeling/planar_bodies.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"
#include "modeling/units.h"

namespace servokit {
namespace {

// The keys of each form of multibody model file: the explicit M(q), f(q, q') (no kind, or
// `kind: multibody`), the energies (`kind: lagrangian`) and the bodies (`kind: planar-bodies`).
// Every form has these, and its own in between.
constexpr std::array<std::string_view, 4> kLeadingKeys = {"name", "parameters", "coordinates",
                                                          "inputs"};
constexpr std::string_view kOutputsKey = "outputs";
constexpr std::string_view kDescriptionKey = "description";
constexpr std::string_view kMassMatrixKey = "mass_matrix";
constexpr std::string_view kForcesKey = "forces";
constexpr std::string_view kInputMatrixKey = "input_matrix";
constexpr std::string_view kKineticEnergyKey = "kinetic_energy";
constexpr std::string_view kPotentialEnergyKey = "potential_energy";
constexpr std::string_view kDissipationKey = "dissipation";
constexpr std::string_view kGeneralizedForcesKey = "generalized_forces";
constexpr std::string_view kConstraintsKey = "constraints";
constexpr std::string_view kStartKey = "q0";

enum class Form { kExplicit, kLagrangian, kPlanarBodies };

struct FormKeys {
  std::vector<std::string_view> required, optional;
};

FormKeys KeysOf(Form form) {
  FormKeys keys;
  keys.required.assign(kLeadingKeys.begin(), kLeadingKeys.end());
  keys.optional = {kDescriptionKey};
  switch (form) {
    case Form::kExplicit:
      keys.required.insert(keys.required.end(), {kMassMatrixKey, kForcesKey, kInputMatrixKey});
      break;
    case Form::kLagrangian:
      keys.required.insert(keys.required.end(),
                           {kKineticEnergyKey, kPotentialEnergyKey, kInputMatrixKey});
      keys.optional.insert(keys.optional.end(), {kDissipationKey, kGeneralizedForcesKey});
      break;
    case Form::kPlanarBodies:
      keys.required.insert(keys.required.end(), detail::kPlanarBodiesRequiredKeys.begin(),
                           detail::kPlanarBodiesRequiredKeys.end());
      keys.optional.insert(keys.optional.end(), detail::kPlanarBodiesOptionalKeys.begin(),
                           detail::kPlanarBodiesOptionalKeys.end());
      break;
  }
  keys.optional.push_back(kConstraintsKey);  // every form: a closed chain's loops
  keys.optional.push_back(kStartKey);        // every form: Newton's start for the equilibrium
  keys.required.push_back(kOutputsKey);
  return keys;
}

// The form the file's `kind` names; modeling/loaded_model.cpp has checked its value already.
Form FormOf(const YAML::Node& root) {
  const YAML::Node kind = root.IsMap() ? root[std::string(detail::kKindKey)] : YAML::Node();
  if (kind && kind.IsScalar() && kind.Scalar() == detail::kLagrangianKind) return Form::kLagrangian;
  if (kind && kind.IsScalar() && kind.Scalar() == detail::kPlanarBodiesKind) {
    return Form::kPlanarBodies;
  }
  return Form::kExplicit;
}

// Optional: the kind of model file; modeling/loaded_model.cpp has read it and dispatched on it
// already.
using detail::FreeTextProblem;
using detail::kKindKey;

using detail::Contains;
using detail::Excerpt;
using detail::FindUnsupported;
using detail::FirstSymbolIn;
using detail::Indexed;
using detail::Join;
using detail::kPiName;
using detail::Text;
constexpr const auto& kFunctions = detail::kModelFunctions;
// The velocity of coordinate c is the symbol c_dot.
constexpr std::string_view kVelocitySuffix = "_dot";
using detail::kQuantityHint;

// Symmetry of M is decided symbolically when expand() or normal() shows M_ij - M_ji = 0;
// otherwise (trigonometric identities, say) by evaluating both at random points near the
// nominal parameters and in q in [-1, 1] rad or m. A fixed seed keeps the verdict reproducible.
// The same points decide whether T - 1/2 q'^T M q' vanishes (T a quadratic form in q'), with
// the velocities in [-1, 1] too.
constexpr int kSymmetryCheckPoints = 5;
constexpr unsigned kSymmetryCheckSeed = 20130101u;
// Relative spread of the parameters around their nominal values at those points.
constexpr double kSymmetryParameterSpread = 0.1;
// Two different forms of the same expression differ by round-off only: a few hundred ulps at
// most for mass-matrix entries, far below this relative tolerance.
constexpr double kSymmetryTolerance = 1e-10;
// M(0) counts as positive definite when its smallest eigenvalue exceeds this fraction of its
// largest: below it, M q'' = ... cannot be solved to double precision.
constexpr double kPositiveDefiniteTolerance = 1e-12;

// "1 row", "2 rows": counts in messages.
std::string Count(std::size_t count, const std::string& singular, const std::string& plural) {
  return std::to_string(count) + " " + (count == 1 ? singular : plural);
}

std::string Indexed(std::string_view key, std::size_t i, std::size_t j) {
  return Indexed(key, i) + "[" + std::to_string(j) + "]";
}

// GiNaC's parse_error text is "GiNaC: parse error at line 0, column 0: <what>\n[<function>...]";
// the position is always 0 for a string, so only <what> helps a user.
std::string ParseErrorMessage(const std::exception& error) {
  std::string message = error.what();
  const std::size_t column = message.find("column ");
  if (column != std::string::npos) {
    const std::size_t colon = message.find(": ", column);
    if (colon != std::string::npos) {
      message.erase(0, colon + 2);
    }
  }
  return message.substr(0, message.find('\n'));
}

// Column-major entries of each matrix, one after the other: the layout Evaluate() copies into
// Eigen storage.
std::vector<GiNaC::ex> ColumnMajor(const std::vector<GiNaC::matrix>& blocks) {
  std::vector<GiNaC::ex> entries;
  for (const GiNaC::matrix& block : blocks) {
    for (unsigned j = 0; j < block.cols(); ++j) {
      for (unsigned i = 0; i < block.rows(); ++i) {
        entries.push_back(block(i, j));
      }
    }
  }
  return entries;
}

}  // namespace

// Fills a Model from YAML text, one checked step at a time (Model names it as its friend).
class ModelBuilder {
 public:
  explicit ModelBuilder(const detail::ModelDocument& document)
      : root_(document.root), form_(FormOf(document.root)) {
    model_.source_ = document.source;
    detail::ContentHasher hasher;
    hasher.Add(document.text);
    model_.content_hash_ = hasher.Hex();
  }

  // A model given by its equations, not a file (ModelFromLinearEquations).
  explicit ModelBuilder(const LinearEquations& equations) : form_(Form::kExplicit) {
    model_.name_ = equations.name;
    model_.description_ = equations.description;
    model_.source_ = equations.source;
    model_.coordinates_ = equations.coordinates;
    model_.inputs_ = equations.inputs;
    model_.parameters_.resize(0);
    // The identity of the numbers themselves: the algebraic inverse's cache is keyed by it.
    detail::ContentHasher hasher;
    const auto add_names = [&hasher](const std::vector<std::string>& names) {
      for (const std::string& name : names) hasher.Add(name + '\n');
    };
    add_names(equations.coordinates);
    add_names(equations.inputs);
    for (const Eigen::MatrixXd* matrix :
         {&equations.mass_matrix, &equations.stiffness, &equations.damping, &equations.input_matrix,
          &equations.output_jacobian}) {
      hasher.Add(std::to_string(matrix->rows()) + "x" + std::to_string(matrix->cols()));
      hasher.Add(std::string_view(reinterpret_cast<const char*>(matrix->data()),
                                  sizeof(double) * std::size_t(matrix->size())));
    }
    model_.content_hash_ = hasher.Hex();
  }

  // The loops of `model` as servo constraints (LoopsAsServoConstraints): its names, parameters
  // and symbols, M and f as they are.
  explicit ModelBuilder(const Model& model) : model_(model), form_(Form::kExplicit) {
    const SymbolicModel& symbolic = model.symbolic();
    parameter_symbols_ = symbolic.parameters();
    coordinate_symbols_ = symbolic.coordinates();
    velocity_symbols_ = symbolic.velocities();
    // Another problem than the file's: the algebraic inverse's cache is keyed by the hash.
    detail::ContentHasher hasher;
    hasher.Add(model.content_hash() + "\nloops as servo constraints\n");
    model_.content_hash_ = hasher.Hex();
  }

  Model BuildLoopsAsServoConstraints() && {
    const SymbolicModel& loops = model_.symbolic();
    const unsigned dof = unsigned(loops.dof());
    const unsigned inputs = unsigned(loops.num_inputs());
    const unsigned outputs = unsigned(loops.num_outputs());
    const unsigned constraints = unsigned(loops.num_constraints());
    GiNaC::matrix input_matrix(dof, inputs + constraints);  // [B C^T]
    GiNaC::matrix output(outputs + constraints, 1);         // [h; c]
    for (unsigned i = 0; i < dof; ++i) {
      for (unsigned k = 0; k < inputs; ++k) input_matrix(i, k) = loops.input_matrix()(i, k);
      for (unsigned k = 0; k < constraints; ++k) {
        input_matrix(i, inputs + k) = loops.constraint_jacobian()(k, i);
      }
    }
    for (unsigned i = 0; i < outputs; ++i) output(i, 0) = loops.output()(i, 0);
    for (unsigned k = 0; k < constraints; ++k) output(outputs + k, 0) = loops.constraints()(k, 0);
    SymbolicModel::Entries mass_matrix =
        loops.canonical_mass_matrix() != nullptr
            ? SymbolicModel::Entries(*loops.canonical_mass_matrix())
            : SymbolicModel::Entries(loops.mass_matrix());
    SymbolicModel::Entries forces = loops.canonical_forces() != nullptr
                                        ? SymbolicModel::Entries(*loops.canonical_forces())
                                        : SymbolicModel::Entries(loops.forces());
    for (unsigned k = 0; k < constraints; ++k) {
      model_.inputs_.push_back(MultiplierName(k));
    }
    model_.num_outputs_ = outputs + constraints;
    model_.num_constraints_ = 0;
    model_.constraint_names_.clear();
    // M's program is the loop model's own: the same expressions.
    std::shared_ptr<const ExpressionProgram> mass_matrix_program =
        model_.programs_[std::size_t(std::countr_zero(unsigned(Quantity::kMassMatrix)))];
    auto symbolic = std::make_shared<const SymbolicModel>(
        parameter_symbols_, coordinate_symbols_, velocity_symbols_, std::move(mass_matrix),
        std::move(forces), std::move(input_matrix), std::move(output));
    Compile(*symbolic, std::move(mass_matrix_program));
    model_.polynomial_ = std::make_shared<Model::LazyPolynomial>();
    model_.polynomial_->compile = PolynomialCompiler(symbolic);
    model_.symbolic_ = std::move(symbolic);
    return std::move(model_);
  }

  Model BuildLinear(const LinearEquations& equations) && {
    const auto dof = Eigen::Index(model_.coordinates_.size());
    const auto inputs = Eigen::Index(model_.inputs_.size());
    const auto outputs = equations.output_jacobian.rows();
    const auto require = [&](const Eigen::MatrixXd& matrix, Eigen::Index rows, Eigen::Index cols,
                             const char* what) {
      if (matrix.rows() != rows || matrix.cols() != cols || !matrix.allFinite()) {
        throw ModelError(model_.source_ + ": " + what + ": expected " + std::to_string(rows) +
                         " x " + std::to_string(cols) + " finite numbers");
      }
    };
    require(equations.mass_matrix, dof, dof, "M");
    require(equations.stiffness, dof, dof, "K");
    require(equations.damping, dof, dof, "D");
    require(equations.input_matrix, dof, inputs, "B");
    require(equations.output_jacobian, inputs, dof, "H (one output per input)");
    MakeSymbols();
    // Whole numbers exact, as the parser reads "0" or "2" in a file (a zero then drops its term,
    // as GiNaC drops a term with an exact zero factor); every other one exactly the double.
    const auto number = [](double value) {
      constexpr double kExactIntegers = 9007199254740992.0;  // 2^53
      if (value == std::floor(value) && std::abs(value) < kExactIntegers) {
        return GiNaC::ex(GiNaC::numeric(static_cast<long>(value)));
      }
      return GiNaC::ex(GiNaC::numeric(value));
    };
    const auto size = [](Eigen::Index count) { return static_cast<unsigned>(count); };
    GiNaC::matrix mass_matrix(size(dof), size(dof));
    GiNaC::matrix forces(size(dof), 1);
    GiNaC::matrix input_matrix(size(dof), size(inputs));
    GiNaC::matrix output(size(outputs), 1);
    for (Eigen::Index i = 0; i < dof; ++i) {
      for (Eigen::Index j = 0; j < dof; ++j) {
        mass_matrix(unsigned(i), unsigned(j)) = number(equations.mass_matrix(i, j));
        forces(unsigned(i), 0) +=
            number(equations.stiffness(i, j)) * coordinate_symbols_[std::size_t(j)] +
            number(equations.damping(i, j)) * velocity_symbols_[std::size_t(j)];
      }
      for (Eigen::Index k = 0; k < inputs; ++k) {
        input_matrix(unsigned(i), unsigned(k)) = number(equations.input_matrix(i, k));
      }
    }
    for (Eigen::Index i = 0; i < outputs; ++i) {
      for (Eigen::Index j = 0; j < dof; ++j) {
        output(unsigned(i), 0) +=
            number(equations.output_jacobian(i, j)) * coordinate_symbols_[std::size_t(j)];
      }
    }
    model_.num_outputs_ = std::size_t(outputs);
    auto symbolic = std::make_shared<const SymbolicModel>(
        parameter_symbols_, coordinate_symbols_, velocity_symbols_, std::move(mass_matrix),
        std::move(forces), std::move(input_matrix), std::move(output));
    Compile(*symbolic, nullptr);
    model_.polynomial_->compile = PolynomialCompiler(symbolic);
    model_.symbolic_ = std::move(symbolic);
    return std::move(model_);
  }

  Model Build(const std::vector<ParameterOverride>& overrides) && {
    CheckTopLevelKeys();
    ReadName();
    ReadParameters();
    ApplyOverrides(overrides);
    model_.coordinates_ = ReadNameList("coordinates");
    model_.inputs_ = ReadNameList("inputs");
    CheckCounts();
    CheckNames();
    MakeSymbols();

    EquationsOfMotion equations = ReadEquationsOfMotion();
    std::shared_ptr<const ExpressionProgram> mass_matrix_program =
        std::move(equations.mass_matrix_program);
    GiNaC::matrix output = ReadOutputs();
    model_.num_outputs_ = model_.num_inputs();
    GiNaC::matrix constraints = ReadConstraints(equations);
    model_.num_constraints_ = constraints.rows();
    ReadStart();

    // GiNaC throws while it differentiates what parses but has no derivative, as 0^x
    // (d/dx = 0^x log 0: "power::eval(): division by zero"; found by fuzzing, issue #7).
    Guarded("derivatives", "cannot differentiate the model's expressions", [&] {
      auto symbolic = std::make_shared<const SymbolicModel>(
          parameter_symbols_, coordinate_symbols_, velocity_symbols_,
          std::move(equations.mass_matrix), std::move(equations.forces),
          std::move(equations.input_matrix), std::move(output), std::move(constraints));
      Compile(*symbolic, std::move(mass_matrix_program));
      model_.polynomial_->compile = PolynomialCompiler(symbolic);
      model_.symbolic_ = std::move(symbolic);
    });
    return std::move(model_);
  }

 private:
  // Read-only lookup: the non-const operator[] of yaml-cpp may add the key it looks up.
  YAML::Node Entry(const std::string& key) const { return std::as_const(root_)[key]; }

  [[noreturn]] void Fail(const std::string& where, const std::string& problem) const {
    throw ModelError(model_.source_ + ": " + where + ": " + problem);
  }

  // Runs a derivation from the file's entries at `where`, its failures said in the file's
  // terms: a derivation past its budget names the entry (ModelError); memory running out within
  // the budgets is no fault of the file (kind kOther, status 1); anything else GiNaC throws is a
  // derivative it cannot take (`cannot`).
  template <class Derivation>
  void Guarded(const std::string& where, const std::string& cannot, Derivation&& derive) const {
    try {
      derive();
    } catch (const Error&) {
      throw;
    } catch (const detail::DerivationTooLarge& error) {
      Fail(where, error.what());
    } catch (const std::bad_alloc&) {
      OutOfMemory(where, "deriving and compiling the equations of motion");
    } catch (const std::exception& error) {
      Fail(where, cannot + ": " + error.what());
    }
  }

  // Memory ran out within the budgets: no fault of the file, so kind kOther (status 1).
  [[noreturn]] void OutOfMemory(const std::string& where, const std::string& doing) const {
    throw Error(model_.source_ + ": " + where + ": out of memory while " + doing +
                ", within the budgets of docs/model-files.md (free memory, or raise the "
                "process's limit)");
  }

  void CheckTopLevelKeys() const {
    const FormKeys keys = KeysOf(form_);
    if (!root_.IsMap()) {
      Fail("top level", "expected a map with the keys " + Join(keys.required) + " and " +
                            Join(keys.optional) + " (optional)");
    }
    std::vector<std::string> seen;
    for (const auto& entry : root_) {
      if (!entry.first.IsScalar()) {
        Fail("top level", "keys must be plain names");
      }
      const std::string& key = entry.first.Scalar();
      if (key != kKindKey && !Contains(keys.required, key) && !Contains(keys.optional, key)) {
        Fail(key, "unknown key (expected " + Join(keys.required) + ", " + Join(keys.optional) +
                      " or " + std::string(kKindKey) + ")");
      }
      if (Contains(seen, key)) {
        Fail(key, "duplicate key");
      }
      seen.push_back(key);
    }
    for (const std::string_view key : keys.required) {
      if (!Contains(seen, key)) {
        Fail(std::string(key), "missing required key");
      }
    }
  }

  void ReadName() {
    const YAML::Node name = Entry("name");
    if (!name.IsScalar() || name.Scalar().empty()) {
      Fail("name", "expected a non-empty string");
    }
    if (const std::optional<std::string> problem = FreeTextProblem(name.Scalar(), false)) {
      Fail("name", *problem);
    }
    model_.name_ = name.Scalar();
    if (const YAML::Node description = Entry(std::string(kDescriptionKey))) {
      if (!description.IsScalar()) {
        Fail(std::string(kDescriptionKey), "expected a string");
      }
      if (const std::optional<std::string> problem = FreeTextProblem(description.Scalar(), true)) {
        Fail(std::string(kDescriptionKey), *problem);
      }
      model_.description_ = description.Scalar();
    }
  }

  void ReadParameters() {
    const YAML::Node parameters = Entry("parameters");
    if (!parameters.IsMap()) {
      Fail("parameters", "expected a map of name: value (use {} for none)");
    }
    std::vector<double> values;
    for (const auto& entry : parameters) {
      if (!entry.first.IsScalar()) {
        Fail("parameters", "parameter names must be plain names");
      }
      const std::string& name = entry.first.Scalar();
      const std::optional<ParsedQuantity> value =
          entry.second.IsScalar() ? ParseQuantityWithUnit(entry.second.Scalar()) : std::nullopt;
      if (!value) {
        Fail("parameters." + name, "not a number " + std::string(kQuantityHint));
      }
      model_.parameter_names_.push_back(name);
      model_.parameter_units_.push_back(value->unit);
      values.push_back(value->value);
    }
    model_.parameters_ =
        Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
  }

  // `q0:`, Newton's start for the operating point (Model::operating_point_start): one number
  // per coordinate, in SI or ending in deg.
  void ReadStart() {
    const std::string key(kStartKey);
    const YAML::Node start = Entry(key);
    if (!start) return;
    const std::size_t dof = model_.coordinates_.size();
    if (!start.IsSequence() || start.size() != dof) {
      Fail(key, "expected a list of " + Count(dof, "number", "numbers") +
                    ", one per coordinate, e.g. [0, 0.5]");
    }
    model_.operating_point_start_.resize(Eigen::Index(dof));
    for (std::size_t i = 0; i < dof; ++i) {
      const std::optional<ParsedQuantity> value =
          start[i].IsScalar() ? ParseQuantityWithUnit(start[i].Scalar()) : std::nullopt;
      if (!value) {
        Fail(Indexed(key, i) + " (" + model_.coordinates_[i] + ")",
             "not a number " + std::string(kQuantityHint));
      }
      model_.operating_point_start_(Eigen::Index(i)) = value->value;
    }
  }

  void ApplyOverrides(const std::vector<ParameterOverride>& overrides) {
    detail::ApplyParameterOverrides(model_.parameter_names_, overrides, model_.parameters_,
                                    model_.parameter_units_);
  }

  std::vector<std::string> ReadNameList(const std::string& key) const {
    const YAML::Node list = Entry(key);
    if (!list.IsSequence()) {
      Fail(key, "expected a list of names, e.g. [x, s]");
    }
    if (list.size() == 0) {
      Fail(key, "expected at least one name");
    }
    std::vector<std::string> names;
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (!list[i].IsScalar()) {
        Fail(Indexed(key, i), "expected a name");
      }
      names.push_back(list[i].Scalar());
    }
    return names;
  }

  void CheckCounts() const {
    if (model_.num_inputs() > model_.dof()) {
      Fail("inputs", Count(model_.num_inputs(), "input", "inputs") + " for " +
                         Count(model_.dof(), "coordinate", "coordinates") +
                         "; a system has at most as many inputs as coordinates");
    }
  }

  // Parameters, coordinates and inputs share one name space (they become CSV columns), and a
  // name must not read as something else in an expression.
  void CheckNames() const {
    std::map<std::string, std::string> owners;  // name -> where it was defined
    const auto check = [&](const std::string& name, const std::string& where) {
      if (auto problem = detail::ReservedNameProblem(name)) Fail(where, *problem);
      for (const std::string& coordinate : model_.coordinates_) {
        if (name == coordinate + std::string(kVelocitySuffix)) {
          Fail(where,
               "name '" + name + "' clashes with the velocity of coordinate '" + coordinate + "'");
        }
      }
      if (const auto [owner, inserted] = owners.emplace(name, where); !inserted) {
        Fail(where, "duplicate name '" + name + "' (also " + owner->second + ")");
      }
    };
    for (const std::string& name : model_.parameter_names_) {
      check(name, "parameters." + name);
    }
    for (std::size_t i = 0; i < model_.coordinates_.size(); ++i) {
      check(model_.coordinates_[i], Indexed("coordinates", i));
    }
    for (std::size_t i = 0; i < model_.inputs_.size(); ++i) {
      check(model_.inputs_[i], Indexed("inputs", i));
    }
  }

  void MakeSymbols() {
    const auto add = [&](const std::string& name, std::vector<GiNaC::realsymbol>& symbols) {
      symbols.emplace_back(name);
      symbol_table_[name] = symbols.back();
    };
    for (const std::string& name : model_.parameter_names_) {
      add(name, parameter_symbols_);
    }
    for (const std::string& name : model_.coordinates_) {
      add(name, coordinate_symbols_);
      add(name + std::string(kVelocitySuffix), velocity_symbols_);
    }
    symbol_table_[std::string(kPiName)] = GiNaC::Pi;
    canonical_ = std::make_shared<CanonicalExpressions>(
        ProgramInputSymbols(parameter_symbols_, coordinate_symbols_, velocity_symbols_));
  }

  // Compiles in the model's store of canonical forms, where the expressions read from the file
  // are already (ExpressionParser): they are not converted again.
  ExpressionProgram CompileInModel(const std::vector<GiNaC::ex>& outputs) const {
    const std::vector<GiNaC::ex> inputs =
        ProgramInputSymbols(parameter_symbols_, coordinate_symbols_, velocity_symbols_);
    if (canonical_ == nullptr) return CompileExpressions(outputs, inputs);
    return CompileExpressions(outputs, inputs, *canonical_);
  }

  // Names in `text` that the parser would reject with a less helpful message, or read as
  // something else; also catches "2x" and characters that are no operator.
  std::optional<std::string> FindLexicalProblem(const std::string& text) const {
    return detail::FindLexicalProblem(
        text, [this](const std::string& name, bool called) { return NameProblem(name, called); });
  }

  std::optional<std::string> NameProblem(const std::string& name, bool called) const {
    if (called) {
      if (!Contains(kFunctions, name)) {
        return "unsupported function '" + name + "' (supported: " + Join(kFunctions) + ")";
      }
      return std::nullopt;
    }
    if (symbol_table_.count(name) != 0) {
      return std::nullopt;
    }
    if (Contains(kFunctions, name)) {
      return "function '" + name + "' needs its argument in parentheses";
    }
    if (Contains(model_.inputs_, name)) {
      return "'" + name + "' is an input; expressions may use parameters, coordinates and " +
             "velocities only";
    }
    return "unknown symbol '" + name + "'";
  }

  // The expression at `node` in the model's store of canonical forms, checked.
  CanonicalExpressions::Scaled ParseExpression(const YAML::Node& node,
                                               const std::string& where) const {
    if (node.IsNull()) {
      Fail(where, "empty expression");
    }
    if (!node.IsScalar()) {
      Fail(where, "expected an expression, found a list or map");
    }
    const std::string& text = node.Scalar();
    if (auto problem = FindLexicalProblem(text)) {
      Fail(where, *problem);
    }
    CanonicalExpressions::Scaled expression;
    try {
      expression = ExpressionParser(*canonical_, symbol_table_).Parse(text);
    } catch (const GiNaC::parse_error& error) {
      Fail(where, "syntax error in \"" + Excerpt(text) + "\": " + ParseErrorMessage(error));
    } catch (const std::bad_alloc&) {
      OutOfMemory(where, "parsing it");
    } catch (const std::exception& error) {
      // GiNaC evaluates what the reader hands it: 1/0 or log(0) throw here.
      Fail(where, "invalid expression \"" + Excerpt(text) + "\": " + error.what());
    }
    if (auto problem = FindUnsupported(*canonical_, expression)) {
      Fail(where, *problem + " in \"" + text + "\"");
    }
    return expression;
  }

  // The same as a GiNaC expression, for what is derived or checked symbolically.
  GiNaC::ex ParseGiNaC(const YAML::Node& node, const std::string& where) const {
    return canonical_->Expression(ParseExpression(node, where));
  }

  GiNaC::matrix ReadMatrix(const std::string& key,
                           std::size_t rows,
                           std::size_t cols,
                           const std::string& column_meaning) const {
    const YAML::Node node = Entry(key);
    if (!node.IsSequence()) {
      Fail(key, "expected a list of rows");
    }
    if (node.size() != rows) {
      Fail(key, "expected " + Count(rows, "row", "rows") + " (one per coordinate), found " +
                    std::to_string(node.size()));
    }
    GiNaC::matrix matrix(static_cast<unsigned>(rows), static_cast<unsigned>(cols));
    for (std::size_t i = 0; i < rows; ++i) {
      const YAML::Node row = node[i];
      if (!row.IsSequence() || row.size() != cols) {
        Fail(Indexed(key, i),
             "expected a row of " + Count(cols, "entry", "entries") + " (one per " +
                 column_meaning + "), found " +
                 (row.IsSequence() ? std::to_string(row.size()) : std::string("no list")));
      }
      for (std::size_t j = 0; j < cols; ++j) {
        matrix(static_cast<unsigned>(i), static_cast<unsigned>(j)) =
            ParseGiNaC(row[j], Indexed(key, i, j));
      }
    }
    return matrix;
  }

  // A list of `size` expressions at `key`, in canonical form.
  CanonicalEntries ReadColumn(const std::string& key,
                              std::size_t size,
                              const std::string& size_meaning) const {
    const YAML::Node node = Entry(key);
    if (!node.IsSequence()) {
      Fail(key, "expected a list of expressions");
    }
    if (node.size() != size) {
      Fail(key, "expected " + Count(size, "entry", "entries") + " (" + size_meaning + "), found " +
                    std::to_string(node.size()));
    }
    CanonicalEntries column{canonical_, {}};
    for (std::size_t i = 0; i < size; ++i) {
      column.entries.push_back(ParseExpression(node[i], Indexed(key, i)));
    }
    return column;
  }

  GiNaC::matrix ReadVector(const std::string& key,
                           std::size_t size,
                           const std::string& size_meaning) const {
    return InGiNaC(ReadColumn(key, size, size_meaning), unsigned(size), 1);
  }

  GiNaC::matrix ReadOutputs() const {
    const YAML::Node node = Entry("outputs");
    // A non-list is reported by ReadVector. Paper Sect. 2: there are as many servo-constraints
    // (outputs) as inputs.
    if (node.IsSequence() && node.size() != model_.num_inputs()) {
      Fail("outputs", Count(node.size(), "output", "outputs") + " for " +
                          Count(model_.num_inputs(), "input", "inputs") +
                          "; servo-constraint problems need as many outputs as inputs");
    }
    GiNaC::matrix output = ReadVector("outputs", model_.num_inputs(), "one per input");
    CheckNoVelocities(output, "outputs", "y = h(q)", /*listed=*/true);
    return output;
  }

  struct EquationsOfMotion {
    SymbolicModel::Entries mass_matrix;  // canonical where derived on canonical forms
    SymbolicModel::Entries forces;       // canonical as the file writes it or so derived
    GiNaC::matrix input_matrix;
    // M's program when the derivation compiled it to check M (Derive); Compile reuses it.
    std::shared_ptr<const ExpressionProgram> mass_matrix_program;
    // Planar bodies' joints: their constraints and names (detail::PlanarBodies).
    std::vector<GiNaC::ex> loop_constraints;
    std::vector<std::string> loop_constraint_names;
  };

  // c(q) = 0, a closed chain's loop-closing constraints (docs/model-files.md, "Closed kinematic
  // chains"): the file's `constraints`, then the planar bodies' joints (`equations`); none (0
  // rows) without either. Names each (Model::constraint_names).
  GiNaC::matrix ReadConstraints(const EquationsOfMotion& equations) {
    const std::string key(kConstraintsKey);
    const YAML::Node node = Entry(key);
    std::vector<GiNaC::ex> rows;
    std::vector<std::string>& names = model_.constraint_names_;
    if (node) {
      if (!node.IsSequence() || node.size() == 0) {
        Fail(key, "expected a list of expressions c(q), one per loop-closing constraint c(q) = 0");
      }
      const GiNaC::matrix written = ReadVector(key, node.size(), "one per constraint");
      CheckNoVelocities(written, key, "c(q)", /*listed=*/true);
      for (unsigned i = 0; i < written.rows(); ++i) {
        rows.push_back(written(i, 0));
        names.push_back(Indexed(key, i));
      }
    }
    rows.insert(rows.end(), equations.loop_constraints.begin(), equations.loop_constraints.end());
    names.insert(names.end(), equations.loop_constraint_names.begin(),
                 equations.loop_constraint_names.end());
    const std::size_t count = rows.size(), dof = model_.dof(), outputs = model_.num_outputs();
    if (count > 0 && (count >= dof || count + outputs > dof)) {
      Fail(node ? key : "joints", Count(count, "constraint", "constraints") + " for " +
                                      Count(dof, "coordinate", "coordinates") + " leave " +
                                      Count(count >= dof ? 0 : dof - count, "degree", "degrees") +
                                      " of freedom for " + Count(outputs, "output", "outputs") +
                                      "; a servo-constraint problem needs at least one per output");
    }
    GiNaC::matrix constraints(unsigned(count), 1);
    for (std::size_t i = 0; i < count; ++i) {
      if (FirstSymbolIn(rows[i], coordinate_symbols_) == nullptr) {
        Fail(names[i],
             "does not depend on the coordinates; a loop-closing constraint c(q) = 0 "
             "relates coordinates");
      }
      constraints(unsigned(i), 0) = rows[i];
    }
    return constraints;
  }

  // M, f and B as the file's form gives them: written out, or derived from the energies.
  EquationsOfMotion ReadEquationsOfMotion() const {
    const std::size_t dof = model_.dof();
    const std::size_t num_inputs = model_.num_inputs();
    const std::string input_matrix_key(kInputMatrixKey);
    EquationsOfMotion equations;
    switch (form_) {
      case Form::kExplicit: {
        const std::string mass_matrix_key(kMassMatrixKey);
        GiNaC::matrix mass_matrix = ReadMatrix(mass_matrix_key, dof, dof, "coordinate");
        CheckNoVelocities(mass_matrix, mass_matrix_key, "M(q)");
        CheckSymmetric(mass_matrix);
        equations.mass_matrix = std::move(mass_matrix);
        equations.forces = ReadColumn(std::string(kForcesKey), dof, "one per coordinate");
        equations.input_matrix = ReadMatrix(input_matrix_key, dof, num_inputs, "input");
        CheckNoVelocities(equations.input_matrix, input_matrix_key, "B(q)");
        return equations;
      }
      case Form::kLagrangian: {
        // Read in canonical form only: derived there (ExpandedLagrangeEquations), T is built
        // in GiNaC only if GiNaC has to derive or check it.
        detail::CanonicalEnergies energies;
        const std::string kinetic_key(kKineticEnergyKey), potential_key(kPotentialEnergyKey);
        energies.kinetic = ParseExpression(Entry(kinetic_key), kinetic_key);
        energies.potential = ParseExpression(Entry(potential_key), potential_key);
        CheckNoVelocities(canonical_->Expression(energies.potential), potential_key, "V(q)");
        const std::string dissipation_key(kDissipationKey);
        energies.dissipation = canonical_->Number(0);
        if (const YAML::Node dissipation = Entry(dissipation_key)) {
          energies.dissipation = ParseExpression(dissipation, dissipation_key);
        }
        const std::string generalized_key(kGeneralizedForcesKey);
        energies.generalized_forces =
            Entry(generalized_key)
                ? ReadColumn(generalized_key, dof, "one per coordinate").entries
                : std::vector<CanonicalExpressions::Scaled>(dof, canonical_->Number(0));
        equations.input_matrix = ReadMatrix(input_matrix_key, dof, num_inputs, "input");
        CheckNoVelocities(equations.input_matrix, input_matrix_key, "B(q)");
        Derive(energies, kinetic_key, KineticEnergy::kWritten, equations);
        return equations;
      }
      case Form::kPlanarBodies: {
        const detail::ExpressionReader read = [this](const YAML::Node& node,
                                                     const std::string& where) {
          return ParseGiNaC(node, where);
        };
        detail::PlanarBodies bodies;
        const std::string cannot = "cannot differentiate the positions and angles";
        Guarded("bodies", cannot, [&] {
          bodies = detail::ReadPlanarBodies(root_, model_.source_, read, model_.coordinates_,
                                            coordinate_symbols_, velocity_symbols_, model_.inputs_);
        });
        equations.input_matrix = std::move(bodies.input_matrix);
        equations.loop_constraints = std::move(bodies.loop_constraints);
        equations.loop_constraint_names = std::move(bodies.loop_constraint_names);
        if (!bodies.projected) {
          Derive(Canonical(bodies.energies), "bodies", KineticEnergy::kOfBodies, equations);
          return equations;
        }
        Guarded("bodies", cannot, [&] {
          equations.mass_matrix_program = CompileMassMatrix(bodies.projected->mass_matrix);
          CheckPositiveDefinite(*equations.mass_matrix_program, "bodies");
        });
        equations.mass_matrix = std::move(bodies.projected->mass_matrix);
        equations.forces = std::move(bodies.projected->forces);
        return equations;
      }
    }
    return equations;
  }

  // Where T comes from: a file's expression, to be checked, or bodies' velocities, a quadratic
  // form by construction (positions and angles free of the velocities, ReadPlanarBodies).
  enum class KineticEnergy { kWritten, kOfBodies };

  // The energies in the model's store of canonical forms.
  detail::CanonicalEnergies Canonical(const detail::Energies& energies) const {
    detail::CanonicalEnergies canonical{canonical_->Add(energies.kinetic),
                                        canonical_->Add(energies.potential),
                                        canonical_->Add(energies.dissipation),
                                        {}};
    for (unsigned i = 0; i < energies.generalized_forces.rows(); ++i) {
      canonical.generalized_forces.push_back(canonical_->Add(energies.generalized_forces(i, 0)));
    }
    return canonical;
  }

  // The same in GiNaC.
  detail::Energies GiNaCEnergies(const detail::CanonicalEnergies& energies) const {
    detail::Energies ginac{canonical_->Expression(energies.kinetic),
                           canonical_->Expression(energies.potential),
                           canonical_->Expression(energies.dissipation),
                           GiNaC::matrix(unsigned(energies.generalized_forces.size()), 1)};
    for (std::size_t i = 0; i < energies.generalized_forces.size(); ++i) {
      ginac.generalized_forces(unsigned(i), 0) =
          canonical_->Expression(energies.generalized_forces[i]);
    }
    return ginac;
  }

  std::vector<CanonicalExpressions::NodeId> Nodes(
      const std::vector<GiNaC::realsymbol>& symbols) const {
    std::vector<CanonicalExpressions::NodeId> nodes;
    for (const GiNaC::realsymbol& symbol : symbols) nodes.push_back(canonical_->Add(symbol).node);
    return nodes;
  }

  // M and f from the energies (modeling/lagrangian_model.h), checked: T a quadratic form in the
  // velocities, M positive definite at q = 0. `kinetic_key` names where T comes from. Derived on
  // the canonical forms where the energies are polynomials in their atoms (a chain of 400
  // pendulums: issue #31), else by GiNaC.
  void Derive(const detail::CanonicalEnergies& energies,
              const std::string& kinetic_key,
              KineticEnergy kinetic_energy,
              EquationsOfMotion& equations) const {
    std::optional<detail::CanonicalEquationsOfMotion> expanded;
    Guarded(kinetic_key, "cannot differentiate the energies", [&] {
      detail::TermBudget budget;
      expanded = detail::ExpandedLagrangeEquations(
          *canonical_, energies, Nodes(coordinate_symbols_), Nodes(velocity_symbols_), budget);
    });
    if (!expanded) {
      DeriveInGiNaC(GiNaCEnergies(energies), kinetic_key, kinetic_energy, equations);
      return;
    }
    Guarded(kinetic_key, "cannot differentiate the energies", [&] {
      // Row by row is column by column (ColumnMajor): M is symmetric by construction.
      equations.mass_matrix_program = std::make_shared<const ExpressionProgram>(CompileExpressions(
          expanded->mass_matrix,
          ProgramInputSymbols(parameter_symbols_, coordinate_symbols_, velocity_symbols_),
          *canonical_));
      CheckMassMatrixFreeOfVelocities(expanded->mass_matrix, kinetic_key);
      if (kinetic_energy == KineticEnergy::kWritten &&
          !detail::ExpandsToQuadraticForm(*canonical_, energies.kinetic, expanded->mass_matrix,
                                          Nodes(velocity_symbols_))) {
        const auto dof = unsigned(model_.dof());
        CheckQuadratic(canonical_->Expression(energies.kinetic),
                       InGiNaC(CanonicalEntries{canonical_, expanded->mass_matrix}, dof, dof),
                       kinetic_key);
      }
      CheckPositiveDefinite(*equations.mass_matrix_program, kinetic_key);
      equations.mass_matrix = CanonicalEntries{canonical_, std::move(expanded->mass_matrix)};
      equations.forces = CanonicalEntries{canonical_, std::move(expanded->forces)};
    });
  }

  // `matrix`'s entries in canonical form, row by row.
  std::vector<CanonicalExpressions::Scaled> Canonical(const GiNaC::matrix& matrix) const {
    std::vector<CanonicalExpressions::Scaled> entries;
    for (unsigned i = 0; i < matrix.rows(); ++i) {
      for (unsigned j = 0; j < matrix.cols(); ++j) entries.push_back(canonical_->Add(matrix(i, j)));
    }
    return entries;
  }

  // Derive by GiNaC's diff().
  void DeriveInGiNaC(const detail::Energies& energies,
                     const std::string& kinetic_key,
                     KineticEnergy kinetic_energy,
                     EquationsOfMotion& equations) const {
    Guarded(kinetic_key, "cannot differentiate the energies", [&] {
      const std::vector<GiNaC::ex> momenta = detail::Momenta(energies.kinetic, velocity_symbols_);
      detail::TermBudget budget;
      GiNaC::matrix mass_matrix = detail::KineticMassMatrix(momenta, velocity_symbols_, budget);
      equations.mass_matrix_program = CompileMassMatrix(mass_matrix);
      CheckMassMatrixFreeOfVelocities(Canonical(mass_matrix), kinetic_key);
      if (kinetic_energy == KineticEnergy::kWritten) {
        CheckQuadratic(energies.kinetic, mass_matrix, kinetic_key);
      }
      CheckPositiveDefinite(*equations.mass_matrix_program, kinetic_key);
      equations.mass_matrix = std::move(mass_matrix);
      equations.forces =
          detail::LagrangeForces(energies, momenta, coordinate_symbols_, velocity_symbols_, budget);
    });
  }

  // T - 1/2 q_dot^T M q_dot vanishes: symbolically where that is cheap, else numerically.
  void CheckQuadratic(const GiNaC::ex& kinetic,
                      const GiNaC::matrix& mass_matrix,
                      const std::string& kinetic_key) const {
    const GiNaC::ex remainder =
        detail::QuadraticFormRemainder(kinetic, mass_matrix, velocity_symbols_);
    // normal() only where its result stays small, function arguments included (normal() works
    // inside them too); a remainder past the budget (a loop closure's T) is decided by the
    // numeric check alone.
    const bool cheap = BoundExpandedTerms(remainder).numerator <= detail::kMaxExpandedTerms &&
                       BoundExpandTerms(remainder) <= detail::kMaxExpandedTerms;
    if (!remainder.is_zero() && !(cheap && GiNaC::normal(remainder).is_zero()) &&
        !AgreeNumerically(kinetic, kinetic - remainder)) {
      Fail(kinetic_key,
           "T is not quadratic in the velocities: T - 1/2 q_dot^T M q_dot = " +
               CanonicalText(remainder) +
               " (terms linear in or free of the velocities; T(q, s q_dot) must be s^2 "
               "T(q, q_dot))");
    }
  }

  // M's program, kept for Compile; M's entries are in the model's store from then on.
  std::shared_ptr<const ExpressionProgram> CompileMassMatrix(
      const GiNaC::matrix& mass_matrix) const {
    return std::make_shared<const ExpressionProgram>(CompileInModel(ColumnMajor({mass_matrix})));
  }

  // d2T/dq_dot2 free of the velocities, as T quadratic in them makes it. Decided on M's
  // canonical forms (`entries`, row by row), each shared node once (a walk of each of the dof^2
  // GiNaC entries took 2 s for 400 coordinates, issue #31).
  void CheckMassMatrixFreeOfVelocities(const std::vector<CanonicalExpressions::Scaled>& entries,
                                       const std::string& kinetic_key) const {
    DependenceOn depends(*canonical_, Nodes(velocity_symbols_));
    const std::size_t dof = model_.dof();
    for (std::size_t i = 0; i < dof; ++i) {
      for (std::size_t j = 0; j < dof; ++j) {
        const CanonicalExpressions::Scaled& entry = entries[i * dof + j];
        if (!depends(entry)) continue;
        const GiNaC::realsymbol* found =
            FirstSymbolIn(canonical_->Expression(entry), velocity_symbols_);
        Fail(kinetic_key, "T is not quadratic in the velocities: d2T/d" +
                              velocity_symbols_[i].get_name() + " d" +
                              velocity_symbols_[j].get_name() + " = " + canonical_->Text(entry) +
                              " depends on the velocity '" +
                              (found != nullptr ? found->get_name() : std::string("?")) + "'");
      }
    }
  }

  // M(0) with the nominal parameters is positive definite; a point where an entry is
  // undefined tells nothing (the analysis checks M again at its operating point). Evaluated by
  // M's compiled program: substituting into dof^2 GiNaC expressions took seconds for 400
  // coordinates (issue #31).
  void CheckPositiveDefinite(const ExpressionProgram& mass_program, const std::string& key) const {
    const auto dof = static_cast<Eigen::Index>(model_.dof());
    std::vector<double> inputs(parameter_symbols_.size() + 2 * model_.dof(), 0.0);
    for (std::size_t k = 0; k < parameter_symbols_.size(); ++k) {
      inputs[k] = model_.parameters_[static_cast<Eigen::Index>(k)];
    }
    std::vector<double> registers(mass_program.num_registers());
    Eigen::MatrixXd mass(dof, dof);
    mass_program.Evaluate(inputs.data(), registers.data(), mass.data());
    if (!mass.allFinite()) return;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(mass, Eigen::EigenvaluesOnly);
    const double smallest = eigen.eigenvalues()(0), largest = eigen.eigenvalues()(dof - 1);
    if (smallest > kPositiveDefiniteTolerance * std::abs(largest)) return;
    std::vector<std::string> massless;
    for (Eigen::Index i = 0; i < dof; ++i) {
      if (mass(i, i) <= 0) massless.push_back(model_.coordinates_[std::size_t(i)]);
    }
    std::ostringstream problem;
    problem.precision(6);
    problem << "the mass matrix d2T/dq_dot2 is not positive definite at q = 0 with the nominal "
               "parameters (smallest eigenvalue "
            << smallest << ", largest " << largest << ")";
    if (!massless.empty()) problem << "; no kinetic energy in the coordinates " << Join(massless);
    Fail(key, problem.str());
  }

  // M(q), B(q) and h(q) are functions of the coordinates only (paper Eqs. 1, 3). `listed`: the
  // file writes `matrix` as a plain list (outputs), so entries are named key[i], not key[i][j].
  void CheckNoVelocities(const GiNaC::matrix& matrix,
                         const std::string& key,
                         const std::string& quantity,
                         bool listed = false) const {
    for (unsigned i = 0; i < matrix.rows(); ++i) {
      for (unsigned j = 0; j < matrix.cols(); ++j) {
        if (const GiNaC::realsymbol* velocity = FirstSymbolIn(matrix(i, j), velocity_symbols_)) {
          Fail(listed ? Indexed(key, i) : Indexed(key, i, j),
               "depends on the velocity '" + velocity->get_name() + "'; " + quantity +
                   " may depend on parameters and coordinates only");
        }
      }
    }
  }

  void CheckNoVelocities(const GiNaC::ex& expression,
                         const std::string& key,
                         const std::string& quantity) const {
    if (const GiNaC::realsymbol* velocity = FirstSymbolIn(expression, velocity_symbols_)) {
      Fail(key, "depends on the velocity '" + velocity->get_name() + "'; " + quantity +
                    " may depend on parameters and coordinates only");
    }
  }

  void CheckSymmetric(const GiNaC::matrix& mass_matrix) const {
    for (unsigned i = 0; i < mass_matrix.rows(); ++i) {
      for (unsigned j = i + 1; j < mass_matrix.cols(); ++j) {
        const GiNaC::ex difference = mass_matrix(i, j) - mass_matrix(j, i);
        if (difference.expand().is_zero() || GiNaC::normal(difference).is_zero() ||
            AgreeNumerically(mass_matrix(i, j), mass_matrix(j, i))) {
          continue;
        }
        Fail(Indexed("mass_matrix", i, j),
             "differs from " + Indexed("mass_matrix", j, i) + " (" + Text(mass_matrix(i, j)) +
                 " vs " + Text(mass_matrix(j, i)) + "); the mass matrix must be symmetric");
      }
    }
  }

  bool AgreeNumerically(const GiNaC::ex& first, const GiNaC::ex& second) const {
    std::mt19937 random(kSymmetryCheckSeed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (int point = 0; point < kSymmetryCheckPoints; ++point) {
      GiNaC::exmap values;
      for (std::size_t k = 0; k < parameter_symbols_.size(); ++k) {
        const double nominal = model_.parameters_[static_cast<Eigen::Index>(k)];
        values[parameter_symbols_[k]] = nominal * (1.0 + kSymmetryParameterSpread * unit(random));
      }
      for (const GiNaC::realsymbol& coordinate : coordinate_symbols_) {
        values[coordinate] = unit(random);
      }
      for (const GiNaC::realsymbol& velocity : velocity_symbols_) {
        values[velocity] = unit(random);
      }
      const std::optional<double> a = EvaluateAt(first, values);
      const std::optional<double> b = EvaluateAt(second, values);
      // A point where an entry is undefined (a pole, a complex value) tells nothing.
      if (a && b && std::abs(*a - *b) > kSymmetryTolerance * std::max(std::abs(*a), std::abs(*b))) {
        return false;
      }
    }
    return true;
  }

  static std::optional<double> EvaluateAt(const GiNaC::ex& expression, const GiNaC::exmap& values) {
    try {
      const GiNaC::ex value = expression.subs(values).evalf();
      if (GiNaC::is_a<GiNaC::numeric>(value) && GiNaC::ex_to<GiNaC::numeric>(value).is_real()) {
        return GiNaC::ex_to<GiNaC::numeric>(value).to_double();
      }
    } catch (const std::exception&) {
      // GiNaC throws on poles such as 1/0; treated as undefined at this point.
    }
    return std::nullopt;
  }

  // A column of 2 dof + 1 coefficients; zeros when the polynomial was not derived.
  static GiNaC::matrix PolynomialBlock(const std::vector<GiNaC::ex>& coefficients,
                                       std::size_t dof) {
    GiNaC::matrix column(unsigned(2 * dof + 1), 1);
    for (std::size_t k = 0; k < coefficients.size(); ++k) column(unsigned(k), 0) = coefficients[k];
    return column;
  }

  // One program per Quantity, at the Quantity's bit position (model.h).
  // `mass_matrix_program`: M's, when the derivation compiled it already (else null).
  void Compile(const SymbolicModel& symbolic,
               std::shared_ptr<const ExpressionProgram> mass_matrix_program) {
    struct Derived {
      Quantity quantity;
      std::string_view name;  // for the error message only
      std::vector<GiNaC::matrix> blocks;
    };
    const std::vector<Derived> quantities = {
        // M derived on canonical forms was compiled from them (mass_matrix_program).
        {Quantity::kMassMatrix, "mass matrix",
         mass_matrix_program != nullptr ? std::vector<GiNaC::matrix>{}
                                        : std::vector<GiNaC::matrix>{symbolic.mass_matrix()}},
        // f read from the file is compiled from its canonical form (below), never built in GiNaC.
        {Quantity::kForces, "forces",
         symbolic.canonical_forces() != nullptr ? std::vector<GiNaC::matrix>{}
                                                : std::vector<GiNaC::matrix>{symbolic.forces()}},
        {Quantity::kInputMatrix, "input matrix", {symbolic.input_matrix()}},
        {Quantity::kOutput, "outputs", {symbolic.output()}},
        {Quantity::kOutputJacobian, "output Jacobian H", {symbolic.output_jacobian()}},
        {Quantity::kOutputBias, "output bias h_bar", {symbolic.output_bias()}},
        {Quantity::kForcesJacobians,
         "Jacobians of f",
         {symbolic.forces_position_jacobian(), symbolic.forces_velocity_jacobian()}},
        {Quantity::kInputMatrixDerivatives, "dB/dq", symbolic.input_matrix_derivatives()},
        {Quantity::kConstraints, "constraints", {symbolic.constraints()}},
        {Quantity::kConstraintJacobian, "constraint Jacobian C", {symbolic.constraint_jacobian()}},
        {Quantity::kConstraintBias, "constraint bias c_bar", {symbolic.constraint_bias()}},
        {Quantity::kConstraintJacobianDerivatives, "dC/dq",
         symbolic.constraint_jacobian_derivatives()},
    };
    static_assert(kNumQuantities == 13, "compile every Quantity (the polynomial on first use)");
    model_.programs_.assign(kNumQuantities, nullptr);
    for (const Derived& derived : quantities) {
      const auto index =
          static_cast<std::size_t>(std::countr_zero(static_cast<unsigned>(derived.quantity)));
      if (derived.quantity == Quantity::kMassMatrix && mass_matrix_program != nullptr) {
        model_.programs_[index] = std::move(mass_matrix_program);
        continue;
      }
      if (IsForwardModeQuantity(derived.quantity) && !symbolic.has_symbolic_jacobians()) {
        continue;  // no program: Evaluate differentiates those of f and B in forward mode
      }
      const CanonicalEntries* canonical = symbolic.canonical_forces();
      try {
        model_.programs_[index] = std::make_shared<const ExpressionProgram>(
            derived.quantity == Quantity::kForces && canonical != nullptr
                ? CompileExpressions(canonical->entries, symbolic.ProgramInputs(),
                                     *canonical->store)
                : CompileInModel(ColumnMajor(derived.blocks)));
      } catch (const std::invalid_argument& error) {
        // Every entry passed FindUnsupported, so this is a derivative GiNaC wrote in a form
        // the compiler does not know; it still comes from the file, so report it as such.
        Fail("derived " + std::string(derived.name), error.what());
      }
    }
  }

  // What Model::polynomial_programs() runs on first use: the polynomial derived, then compiled
  // alone and with M, f, B and H (kPolynomialPathQuantities, in Quantity order). A form the
  // compiler does not know (none is known: the polynomial's entries are polynomials in those
  // compiled above), or a derivation GiNaC refuses, leaves the model without a polynomial:
  // sweeps then take the eigenvalue route.
  static std::function<Model::PolynomialPrograms()> PolynomialCompiler(
      std::shared_ptr<const SymbolicModel> symbolic) {
    if (!symbolic->has_zero_dynamics_polynomial()) return nullptr;
    return [symbolic = std::move(symbolic)]() -> Model::PolynomialPrograms {
      const SymbolicLock lock;
      SymbolicModel::ZeroDynamicsPolynomial polynomial;
      try {
        polynomial = symbolic->DeriveZeroDynamicsPolynomial();
      } catch (const std::exception&) {
        return {};  // GiNaC found no normal form (a pole): the eigenvalue route, as at load
      }
      const std::vector<GiNaC::matrix> alone = {
          PolynomialBlock(polynomial.coefficients, symbolic->dof()),
          PolynomialBlock(polynomial.scales, symbolic->dof())};
      const std::vector<GiNaC::matrix> combined = {
          symbolic->mass_matrix(),     symbolic->forces(), symbolic->input_matrix(),
          symbolic->output_jacobian(), alone[0],           alone[1]};
      static_assert(kPolynomialPathQuantities ==
                        (Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix |
                         Quantity::kOutputJacobian | Quantity::kZeroDynamicsPolynomial),
                    "the combined program's blocks, in Quantity order");
      const std::vector<GiNaC::ex> inputs = symbolic->ProgramInputs();
      try {
        return Model::PolynomialPrograms{std::make_shared<const ExpressionProgram>(
                                             CompileExpressions(ColumnMajor(alone), inputs)),
                                         std::make_shared<const ExpressionProgram>(
                                             CompileExpressions(ColumnMajor(combined), inputs))};
      } catch (const std::exception&) {
        return Model::PolynomialPrograms{};
      }
    };
  }

  Model model_;
  YAML::Node root_;
  Form form_;
  GiNaC::symtab symbol_table_;
  std::vector<GiNaC::realsymbol> parameter_symbols_, coordinate_symbols_, velocity_symbols_;
  // Every expression of the model in canonical form, from reading to compiling (MakeSymbols).
  std::shared_ptr<CanonicalExpressions> canonical_;
};

Model LoopsAsServoConstraints(const Model& model) {
  if (model.num_constraints() == 0) return model;
  const SymbolicLock lock;
  return ModelBuilder(model).BuildLoopsAsServoConstraints();
}

Model ModelFromLinearEquations(const LinearEquations& equations) {
  const SymbolicLock lock;
  return ModelBuilder(equations).BuildLinear(equations);
}

namespace detail {

Model BuildModel(const ModelDocument& document, const std::vector<ParameterOverride>& overrides) {
  return ModelBuilder(document).Build(overrides);
}

}  // namespace detail

}  // namespace servokit
