// LoadLinearModel: linear model file (modeling/linear_model.h) -> checked terms with compiled
// factors. Every problem with the file is one ModelError "file: key: entry: problem", raised
// where it is found; problems inside a Matrix Market file add that file and its line.
#include "modeling/linear_model.h"

#include <ginac/ginac.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include "base/errors.h"
#include "base/number_format.h"
#include "files/input_file.h"
#include "files/output_file.h"
#include "modeling/canonical_expression.h"
#include "modeling/expression_parser.h"
#include "modeling/expression_program.h"
#include "modeling/loader_support.h"
#include "modeling/matrix_market.h"
#include "modeling/units.h"

namespace servokit {
namespace {

using detail::kLinearKind;

constexpr std::array<std::string_view, 6> kRequiredKeys = {
    "name", "kind", "mass_matrix", "stiffness_matrix", "input_matrix", "output_matrix"};
constexpr std::array<std::string_view, 4> kOptionalKeys = {"description", "parameters",
                                                           "damping_matrix", "constraint_matrix"};
constexpr std::string_view kMatrixKey = "matrix";
constexpr std::string_view kFactorKey = "factor";
constexpr std::string_view kDefaultFactor = "1";

using detail::Contains;
using detail::ContentHasher;
using detail::FindUnsupported;
using detail::FreeTextProblem;
using detail::Indexed;
using detail::IsIdentifierChar;
using detail::Join;
using detail::kPiName;
constexpr const auto& kFunctions = detail::kModelFunctions;
using detail::kQuantityHint;

// A mass-matrix term counts as symmetric when |A - A^T| <= this * max |A| entrywise: files
// written by other tools may carry round-off in the last digits, nothing more.
constexpr double kSymmetryTolerance = 1e-12;

std::string Shape(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + " x " + std::to_string(cols);
}

// Same pattern and the same bits in every stored value.
bool Identical(const SparseMatrix& a, const SparseMatrix& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.nonZeros() != b.nonZeros()) return false;
  if (!a.isCompressed() || !b.isCompressed()) {
    SparseMatrix compressed_a = a, compressed_b = b;
    compressed_a.makeCompressed();
    compressed_b.makeCompressed();
    return Identical(compressed_a, compressed_b);
  }
  const auto same = [](const auto* first, const auto* second, Eigen::Index count) {
    return std::memcmp(first, second, static_cast<std::size_t>(count) * sizeof(*first)) == 0;
  };
  return same(a.outerIndexPtr(), b.outerIndexPtr(), a.cols() + 1) &&
         same(a.innerIndexPtr(), b.innerIndexPtr(), a.nonZeros()) &&
         same(a.valuePtr(), b.valuePtr(), a.nonZeros());
}

// The sum of factor * matrix over a term list, with the union pattern (Eigen's sparse sum and
// scalar product keep every stored entry, zeros included).
SparseMatrix SumTerms(const std::vector<LinearModelTerm>& terms,
                      const Eigen::Ref<const Eigen::VectorXd>& parameters,
                      const LinearModel& model,
                      std::string_view key) {
  SparseMatrix sum(static_cast<Eigen::Index>(model.dof()), static_cast<Eigen::Index>(model.dof()));
  std::vector<double> registers;
  const Eigen::VectorXd values = parameters;  // contiguous, whatever the Ref's stride
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const LinearModelTerm& term = terms[k];
    registers.resize(term.factor->num_registers());
    double factor = 0.0;
    term.factor->Evaluate(values.data(), registers.data(), &factor);
    if (!std::isfinite(factor)) {
      throw ModelError(model.source() + ": " + Indexed(key, k) + "." + std::string(kFactorKey) +
                       ": " + term.factor_text + " = " + FormatShortest(factor) +
                       " at these parameter values");
    }
    if (k == 0) {
      sum = factor * term.matrix;
    } else {
      sum = sum + factor * term.matrix;
    }
  }
  sum.makeCompressed();
  return sum;
}

}  // namespace

// Fills a LinearModel from a parsed model file of `kind: linear`, one checked step at a time
// (LinearModel names it as its friend). Matrix files are relative to the model file.
class LinearModelBuilder {
 public:
  explicit LinearModelBuilder(const detail::ModelDocument& document)
      : root_(document.root), directory_(std::filesystem::path(document.source).parent_path()) {
    model_.source_ = document.source;
    hasher_.Add(document.text);
  }

  LinearModel Build(const std::vector<ParameterOverride>& overrides) && {
    CheckTopLevelKeys();
    ReadName();
    ReadParameters();
    ApplyOverrides(overrides);
    MakeSymbols();
    model_.mass_terms_ = ReadTerms("mass_matrix");
    model_.dof_ = static_cast<std::size_t>(model_.mass_terms_.front().matrix.rows());
    if (Entry("damping_matrix")) model_.damping_terms_ = ReadTerms("damping_matrix");
    model_.stiffness_terms_ = ReadTerms("stiffness_matrix");
    CheckSquareTerms("mass_matrix", model_.mass_terms_);
    CheckSymmetricTerms("mass_matrix", model_.mass_terms_);
    CheckSquareTerms("damping_matrix", model_.damping_terms_);
    CheckSquareTerms("stiffness_matrix", model_.stiffness_terms_);
    model_.input_matrix_ = ReadFixedMatrix("input_matrix");
    model_.output_matrix_ = ReadFixedMatrix("output_matrix");
    CheckInputsAndOutputs();
    if (Entry("constraint_matrix")) {
      model_.constraint_matrix_ = ReadFixedMatrix("constraint_matrix");
      CheckConstraints();
    } else {
      model_.constraint_matrix_.resize(0, Eigen::Index(model_.dof_));
    }
    model_.content_hash_ = hasher_.Hex();
    return std::move(model_);
  }

 private:
  YAML::Node Entry(const std::string& key) const { return std::as_const(root_)[key]; }

  [[noreturn]] void Fail(const std::string& where, const std::string& problem) const {
    throw ModelError(model_.source_ + ": " + where + ": " + problem);
  }

  std::string KnownKeys() const {
    return Join(kRequiredKeys) + " and (optional) " + Join(kOptionalKeys);
  }

  void CheckTopLevelKeys() const {
    if (!root_.IsMap()) Fail("top level", "expected a map with the keys " + KnownKeys());
    std::vector<std::string> seen;
    for (const auto& entry : root_) {
      if (!entry.first.IsScalar()) Fail("top level", "keys must be plain names");
      const std::string& key = entry.first.Scalar();
      if (!Contains(kRequiredKeys, key) && !Contains(kOptionalKeys, key)) {
        Fail(key, "unknown key (expected " + KnownKeys() + ")");
      }
      if (Contains(seen, key)) Fail(key, "duplicate key");
      seen.push_back(key);
    }
    for (const std::string_view key : kRequiredKeys) {
      if (!Contains(seen, key)) Fail(std::string(key), "missing required key");
    }
  }

  void ReadName() {
    const YAML::Node name = Entry("name");
    if (!name.IsScalar() || name.Scalar().empty()) Fail("name", "expected a non-empty string");
    if (const std::optional<std::string> problem = FreeTextProblem(name.Scalar(), false)) {
      Fail("name", *problem);
    }
    model_.name_ = name.Scalar();
    if (const YAML::Node description = Entry("description")) {
      if (!description.IsScalar()) Fail("description", "expected a string");
      if (const std::optional<std::string> problem = FreeTextProblem(description.Scalar(), true)) {
        Fail("description", *problem);
      }
      model_.description_ = description.Scalar();
    }
  }

  void ReadParameters() {
    std::vector<double> values;
    if (const YAML::Node parameters = Entry("parameters"); parameters && !parameters.IsNull()) {
      if (!parameters.IsMap()) Fail("parameters", "expected a map of name: value");
      for (const auto& entry : parameters) {
        if (!entry.first.IsScalar()) Fail("parameters", "parameter names must be plain names");
        const std::string& name = entry.first.Scalar();
        const std::string where = "parameters." + name;
        CheckParameterName(name, where);
        const std::optional<ParsedQuantity> value =
            entry.second.IsScalar() ? ParseQuantityWithUnit(entry.second.Scalar()) : std::nullopt;
        if (!value) Fail(where, "not a number " + std::string(kQuantityHint));
        model_.parameter_names_.push_back(name);
        model_.parameter_units_.push_back(value->unit);
        values.push_back(value->value);
      }
    }
    model_.parameters_ =
        Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
  }

  void CheckParameterName(const std::string& name, const std::string& where) const {
    if (auto problem = detail::ReservedNameProblem(name)) Fail(where, *problem);
    if (Contains(model_.parameter_names_, name)) Fail(where, "duplicate parameter");
  }

  void ApplyOverrides(const std::vector<ParameterOverride>& overrides) {
    detail::ApplyParameterOverrides(model_.parameter_names_, overrides, model_.parameters_,
                                    model_.parameter_units_);
  }

  void MakeSymbols() {
    for (const std::string& name : model_.parameter_names_) {
      parameter_symbols_.emplace_back(GiNaC::realsymbol(name));
      symbol_table_[name] = parameter_symbols_.back();
    }
    symbol_table_[std::string(kPiName)] = GiNaC::Pi;
  }

  // A term list: one file name, or a list of {matrix: FILE, factor: EXPRESSION}. Records where
  // each term is written (key or key[k]) for later messages.
  std::vector<LinearModelTerm> ReadTerms(const std::string& key) {
    const YAML::Node node = Entry(key);
    const std::string hint = "expected a file name or a list of {matrix: FILE, factor: EXPRESSION}";
    std::vector<LinearModelTerm> terms;
    std::vector<std::string>& places = term_places_[key];
    if (node.IsScalar()) {
      terms.push_back(MakeTerm(key, key, node.Scalar(), std::string(kDefaultFactor)));
      places.push_back(key);
      return terms;
    }
    if (!node.IsSequence() || node.size() == 0) Fail(key, hint);
    for (std::size_t k = 0; k < node.size(); ++k) {
      const std::string where = Indexed(key, k);
      const YAML::Node term = node[k];
      if (!term.IsMap()) Fail(where, hint);
      for (const auto& entry : term) {
        if (!entry.first.IsScalar() ||
            (entry.first.Scalar() != kMatrixKey && entry.first.Scalar() != kFactorKey)) {
          Fail(where, "unknown key (expected matrix and factor)");
        }
      }
      const YAML::Node matrix = term[std::string(kMatrixKey)];
      if (!matrix) Fail(where + "." + std::string(kMatrixKey), "missing required key");
      if (!matrix.IsScalar()) Fail(where + "." + std::string(kMatrixKey), "expected a file name");
      std::string factor(kDefaultFactor);
      if (const YAML::Node factor_node = term[std::string(kFactorKey)]) {
        if (!factor_node.IsScalar() || factor_node.Scalar().empty()) {
          Fail(where + "." + std::string(kFactorKey), "expected an expression of the parameters");
        }
        factor = factor_node.Scalar();
      }
      terms.push_back(MakeTerm(where + "." + std::string(kMatrixKey),
                               where + "." + std::string(kFactorKey), matrix.Scalar(), factor));
      places.push_back(where);
    }
    return terms;
  }

  LinearModelTerm MakeTerm(const std::string& matrix_place,
                           const std::string& factor_place,
                           const std::string& file,
                           const std::string& factor_text) {
    LinearModelTerm term;
    term.matrix = ReadMatrixFile(matrix_place, file);
    term.factor_text = factor_text;
    term.factor = CompileFactor(factor_place, factor_text);
    return term;
  }

  // Reads and parses one Matrix Market file (relative to the model file); the same file named
  // twice (D = beta K, say) is read once.
  SparseMatrix ReadMatrixFile(const std::string& where, const std::string& file) {
    if (file.empty()) Fail(where, "expected a file name");
    const std::filesystem::path path =
        std::filesystem::path(file).is_absolute() ? std::filesystem::path(file) : directory_ / file;
    const std::string path_text = path.string();
    if (const auto cached = matrices_.find(path_text); cached != matrices_.end()) {
      return cached->second;
    }
    std::string reason;
    const std::optional<std::string> bytes = TryReadInputFile(path_text, kMatrixFileLimit, reason);
    if (!bytes) Fail(where, "cannot read the matrix file " + path_text + " (" + reason + ")");
    hasher_.Add(*bytes);
    try {
      SparseMatrix matrix = ParseMatrixMarket(*bytes, path_text);
      matrices_.emplace(path_text, matrix);
      return matrix;
    } catch (const ModelError& error) {
      Fail(where, error.what());
    }
  }

  // Names in a factor: a parameter, pi, or a function followed by '('. Catches what GiNaC's
  // parser would report less clearly, or accept as one of its own functions.
  std::optional<std::string> FindNameProblem(const std::string& text) const {
    return detail::FindLexicalProblem(
        text, [this](const std::string& name, bool called) -> std::optional<std::string> {
          if (called && !Contains(kFunctions, name)) {
            return "unsupported function '" + name + "' (supported: " + Join(kFunctions) + ")";
          }
          if (!called && symbol_table_.count(name) == 0) {
            return "unknown symbol '" + name + "' (a factor may use the parameters" +
                   (model_.parameter_names_.empty() ? std::string(", and there are none")
                                                    : " " + Join(model_.parameter_names_)) +
                   ", pi and numbers)";
          }
          return std::nullopt;
        });
  }

  std::shared_ptr<const ExpressionProgram> CompileFactor(const std::string& where,
                                                         const std::string& text) const {
    if (auto problem = FindNameProblem(text)) Fail(where, *problem + " in \"" + text + "\"");
    std::vector<GiNaC::ex> inputs(parameter_symbols_.begin(), parameter_symbols_.end());
    CanonicalExpressions canonical(inputs);
    CanonicalExpressions::Scaled expression;
    try {
      expression = ExpressionParser(canonical, symbol_table_).Parse(text);
    } catch (const std::exception& error) {
      // Syntax errors, and what GiNaC evaluates for the reader (1/0).
      std::string message = error.what();
      Fail(where, "invalid expression \"" + text + "\": " + message.substr(0, message.find('\n')));
    }
    if (auto problem = FindUnsupported(canonical, expression)) {
      Fail(where, *problem + " in \"" + text + "\"");
    }
    std::shared_ptr<const ExpressionProgram> program;
    try {
      program = std::make_shared<const ExpressionProgram>(
          CompileExpressions(std::vector{expression}, inputs, canonical));
    } catch (const std::invalid_argument& error) {
      Fail(where, error.what());
    }
    std::vector<double> registers(program->num_registers());
    double value = 0.0;
    program->Evaluate(model_.parameters_.data(), registers.data(), &value);
    if (!std::isfinite(value)) {
      Fail(where, text + " = " + FormatShortest(value) + " at the nominal parameter values");
    }
    return program;
  }

  void CheckSquareTerms(const std::string& key, const std::vector<LinearModelTerm>& terms) const {
    const auto dof = static_cast<Eigen::Index>(model_.dof_);
    for (std::size_t k = 0; k < terms.size(); ++k) {
      const SparseMatrix& matrix = terms[k].matrix;
      if (matrix.rows() != dof || matrix.cols() != dof) {
        Fail(term_places_.at(key).at(k), "expected " + Shape(dof, dof) +
                                             " (dof x dof, dof from mass_matrix), found " +
                                             Shape(matrix.rows(), matrix.cols()));
      }
    }
  }

  void CheckSymmetricTerms(const std::string& key,
                           const std::vector<LinearModelTerm>& terms) const {
    for (std::size_t k = 0; k < terms.size(); ++k) {
      const SparseMatrix& matrix = terms[k].matrix;
      if (matrix.nonZeros() == 0) continue;
      const SparseMatrix asymmetry = matrix - SparseMatrix(matrix.transpose());
      const double size = matrix.coeffs().cwiseAbs().maxCoeff();
      if (asymmetry.nonZeros() > 0 &&
          asymmetry.coeffs().cwiseAbs().maxCoeff() > kSymmetryTolerance * size) {
        Fail(term_places_.at(key).at(k), "the matrix is not symmetric; a mass matrix must be");
      }
    }
  }

  SparseMatrix ReadFixedMatrix(const std::string& key) {
    const YAML::Node node = Entry(key);
    if (!node.IsScalar()) Fail(key, "expected a file name (B and C have no factors)");
    return ReadMatrixFile(key, node.Scalar());
  }

  void CheckInputsAndOutputs() {
    const SparseMatrix& input = model_.input_matrix_;
    const SparseMatrix& output = model_.output_matrix_;
    const auto dof = static_cast<Eigen::Index>(model_.dof_);
    if (input.rows() != dof) {
      Fail("input_matrix", "expected " + std::to_string(dof) + " rows (dof x inputs), found " +
                               Shape(input.rows(), input.cols()));
    }
    if (input.cols() > dof) {
      Fail("input_matrix", std::to_string(input.cols()) + " inputs for " + std::to_string(dof) +
                               " coordinates; a system has at most as many inputs as coordinates");
    }
    if (output.cols() != dof) {
      Fail("output_matrix", "expected " + std::to_string(dof) + " columns (outputs x dof), found " +
                                Shape(output.rows(), output.cols()));
    }
    if (output.rows() != input.cols()) {
      Fail("output_matrix",
           std::to_string(output.rows()) + " outputs for " + std::to_string(input.cols()) +
               " inputs; servo-constraint problems need as many outputs as inputs");
    }
    model_.num_inputs_ = static_cast<std::size_t>(input.cols());
    model_.num_outputs_ = static_cast<std::size_t>(output.rows());
  }

  // G (constraints x dof) of a closed chain: as many columns as coordinates, and room left for
  // the outputs (dof - constraints >= outputs).
  void CheckConstraints() {
    const SparseMatrix& constraints = model_.constraint_matrix_;
    const auto dof = static_cast<Eigen::Index>(model_.dof_);
    if (constraints.cols() != dof) {
      Fail("constraint_matrix", "expected " + std::to_string(dof) +
                                    " columns (constraints x dof), found " +
                                    Shape(constraints.rows(), constraints.cols()));
    }
    if (constraints.rows() < 1 ||
        dof - constraints.rows() < static_cast<Eigen::Index>(model_.num_outputs_)) {
      Fail("constraint_matrix",
           std::to_string(constraints.rows()) + " constraints for " + std::to_string(dof) +
               " coordinates leave " + std::to_string(dof - constraints.rows()) +
               " degrees of freedom for " + std::to_string(model_.num_outputs_) + " outputs");
    }
  }

  LinearModel model_;
  YAML::Node root_;
  std::filesystem::path directory_;
  ContentHasher hasher_;
  std::map<std::string, SparseMatrix> matrices_;                 // by path, each file parsed once
  std::map<std::string, std::vector<std::string>> term_places_;  // by key: key or key[k]
  GiNaC::symtab symbol_table_;
  std::vector<GiNaC::realsymbol> parameter_symbols_;
};

std::optional<std::size_t> LinearModel::FindParameter(std::string_view name) const {
  const auto found = std::find(parameter_names_.begin(), parameter_names_.end(), name);
  if (found == parameter_names_.end()) return std::nullopt;
  return static_cast<std::size_t>(found - parameter_names_.begin());
}

LinearMatrices AssembleLinearMatrices(const LinearModel& model,
                                      const Eigen::Ref<const Eigen::VectorXd>& parameters) {
  if (static_cast<std::size_t>(parameters.size()) != model.parameter_names().size()) {
    throw UsageError("AssembleLinearMatrices: " + std::to_string(parameters.size()) +
                     " parameter values for the " + std::to_string(model.parameter_names().size()) +
                     " parameters of " + model.source());
  }
  LinearMatrices matrices;
  matrices.mass = SumTerms(model.mass_terms(), parameters, model, "mass_matrix");
  matrices.damping = SumTerms(model.damping_terms(), parameters, model, "damping_matrix");
  matrices.stiffness = SumTerms(model.stiffness_terms(), parameters, model, "stiffness_matrix");
  return matrices;
}

namespace detail {

LinearModel BuildLinearModel(const ModelDocument& document,
                             const std::vector<ParameterOverride>& overrides) {
  return LinearModelBuilder(document).Build(overrides);
}

}  // namespace detail

namespace {

// A name that is safe as the start of a file name on every system.
bool IsFileStem(std::string_view name) {
  return !name.empty() && name.front() != '.' && std::all_of(name.begin(), name.end(), [](char c) {
    return IsIdentifierChar(c) || c == '-' || c == '.';
  });
}

// The short letter of each matrix in the file names (NAME.M.mtx and so on).
struct MatrixFile {
  std::string_view key;
  std::string_view letter;
};
constexpr MatrixFile kMass = {"mass_matrix", "M"};
constexpr MatrixFile kDamping = {"damping_matrix", "D"};
constexpr MatrixFile kStiffness = {"stiffness_matrix", "K"};
constexpr MatrixFile kInput = {"input_matrix", "B"};
constexpr MatrixFile kOutput = {"output_matrix", "C"};
constexpr MatrixFile kConstraint = {"constraint_matrix", "G"};

class ModelWriter {
 public:
  ModelWriter(const LinearModelFiles& files, std::filesystem::path directory)
      : files_(files), directory_(std::move(directory)) {}

  std::string Write() {
    YAML::Emitter yaml;
    yaml << YAML::BeginMap;
    yaml << YAML::Key << "name" << YAML::Value << files_.name;
    yaml << YAML::Key << "kind" << YAML::Value << std::string(kLinearKind);
    if (!files_.description.empty()) {
      yaml << YAML::Key << "description" << YAML::Value << files_.description;
    }
    if (!files_.parameters.empty()) {
      yaml << YAML::Key << "parameters" << YAML::Value << YAML::BeginMap;
      for (const auto& [name, value] : files_.parameters) {
        yaml << YAML::Key << name << YAML::Value << FormatShortest(value);
      }
      yaml << YAML::EndMap;
    }
    WriteTerms(yaml, kMass, files_.mass);
    if (!files_.damping.empty()) WriteTerms(yaml, kDamping, files_.damping);
    WriteTerms(yaml, kStiffness, files_.stiffness);
    yaml << YAML::Key << std::string(kInput.key) << YAML::Value
         << WriteMatrix(files_.input_matrix, kInput, 0, 1, "");
    yaml << YAML::Key << std::string(kOutput.key) << YAML::Value
         << WriteMatrix(files_.output_matrix, kOutput, 0, 1, "");
    if (files_.constraint_matrix.rows() > 0) {
      yaml << YAML::Key << std::string(kConstraint.key) << YAML::Value
           << WriteMatrix(files_.constraint_matrix, kConstraint, 0, 1, "");
    }
    yaml << YAML::EndMap;
    if (!yaml.good()) throw UsageError("cannot write the model file: " + yaml.GetLastError());
    const std::filesystem::path path = directory_ / (files_.name + ".yaml");
    OutputFile file(path.string());
    file.Write(yaml.c_str());
    file.Write("\n");
    file.Commit();
    return path.string();
  }

 private:
  void WriteTerms(YAML::Emitter& yaml,
                  const MatrixFile& file,
                  const std::vector<std::pair<SparseMatrix, std::string>>& terms) {
    yaml << YAML::Key << std::string(file.key) << YAML::Value;
    if (terms.size() == 1 && terms.front().second == kDefaultFactor) {
      yaml << WriteMatrix(terms.front().first, file, 0, 1, terms.front().second);
      return;
    }
    yaml << YAML::BeginSeq;
    for (std::size_t k = 0; k < terms.size(); ++k) {
      yaml << YAML::Flow << YAML::BeginMap;
      yaml << YAML::Key << std::string(kMatrixKey) << YAML::Value
           << WriteMatrix(terms[k].first, file, k, terms.size(), terms[k].second);
      yaml << YAML::Key << std::string(kFactorKey) << YAML::Value << terms[k].second;
      yaml << YAML::EndMap;
    }
    yaml << YAML::EndSeq;
  }

  // Writes one matrix unless an identical one was written already; returns its file name.
  std::string WriteMatrix(const SparseMatrix& matrix,
                          const MatrixFile& file,
                          std::size_t term,
                          std::size_t num_terms,
                          const std::string& factor) {
    for (const auto& [written, name] : written_) {
      if (Identical(*written, matrix)) return name;
    }
    std::string name = files_.name + "." + std::string(file.letter);
    if (num_terms > 1) name += "." + std::to_string(term + 1);
    name += ".mtx";
    std::string comment = files_.name + ": " + std::string(file.key);
    if (num_terms > 1) comment += " term " + std::to_string(term + 1);
    if (!factor.empty()) comment += " (times " + factor + ")";
    WriteMatrixMarket(matrix, (directory_ / name).string(), comment);
    written_.emplace_back(&matrix, name);
    return name;
  }

  const LinearModelFiles& files_;
  std::filesystem::path directory_;
  std::vector<std::pair<const SparseMatrix*, std::string>> written_;
};

}  // namespace

std::string WriteLinearModel(const LinearModelFiles& files, const std::string& directory) {
  if (!IsFileStem(files.name)) {
    throw UsageError("model name '" + files.name +
                     "': use letters, digits, _, - and . (not first) so that it names files");
  }
  std::error_code error;
  if (!std::filesystem::is_directory(directory, error)) {
    throw UsageError(directory + ": no such directory");
  }
  return ModelWriter(files, directory).Write();
}

}  // namespace servokit
