#pragma once
// Large linear(ized) models (issue #6): M q'' + D q' + K q = B u,  y = C q, with sparse M, D, K
// (dof x dof), B (dof x inputs) and C (outputs x dof) read from Matrix Market files. They skip
// the symbolic layer (docs/model-files.md, "How servokit reads a model"): no GiNaC, no expressions
// per entry, only a few scalar factors.
//
// The model file (YAML, `kind: linear`; file names relative to the model file):
//
//   name: chain_1000
//   kind: linear
//   description: chain of 1000 masses, force on mass 1, output at mass 1
//   parameters:              # optional; SI; "<number> deg" allowed as in the nonlinear format
//     d: 0.1
//   mass_matrix: chain_1000.M.mtx
//   damping_matrix:          # optional (zero when absent)
//     - {matrix: chain_1000.D.mtx, factor: d}
//   stiffness_matrix: chain_1000.K.mtx
//   input_matrix: chain_1000.B.mtx
//   output_matrix: chain_1000.C.mtx
//   constraint_matrix: ring.G.mtx   # optional: a closed chain's G q = 0 (constraints x dof)
//
// Each of mass_matrix, damping_matrix and stiffness_matrix is either one file name or a list of
// terms {matrix: FILE, factor: EXPRESSION}; the matrix is the sum of factor * matrix over the
// terms. A factor is an expression of the parameters only (numbers, parameters, + - * / ^,
// functions as in the nonlinear format); default 1. The sparsity pattern of each assembled
// matrix is the union of its terms' patterns and does not depend on the parameter values, so a
// sweep analyses the pattern once and only refactorises per point.
#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "modeling/model.h"  // ParameterOverride

namespace servokit {

using SparseMatrix = Eigen::SparseMatrix<double>;  // column-major, int indices

/// One term factor * matrix of an assembled matrix. `factor` is evaluated from the parameters
/// by LinearModel::Assemble; the matrix is shared by all points of a sweep.
struct LinearModelTerm {
  SparseMatrix matrix;
  std::string factor_text;  // as written in the file ("1" when absent), for messages
  // The factor compiled to a function of the parameter vector (order of parameter_names()).
  std::shared_ptr<const ExpressionProgram> factor;
};

/// An immutable, thread-shareable linear model (see the file comment for the file format).
class LinearModel {
 public:
  const std::string& name() const { return name_; }
  const std::string& description() const { return description_; }
  /// The model file path as given, used in error messages.
  const std::string& source() const { return source_; }
  /// FNV-1a 64-bit hash of the model file's bytes and of every matrix file's bytes, as 16 hex
  /// digits (sweep.json records it, as for nonlinear models).
  const std::string& content_hash() const { return content_hash_; }

  std::size_t dof() const { return dof_; }
  std::size_t num_inputs() const { return num_inputs_; }
  std::size_t num_outputs() const { return num_outputs_; }
  const std::vector<std::string>& parameter_names() const { return parameter_names_; }
  /// Nominal parameter values (SI) after overrides, in the order of parameter_names().
  const Eigen::VectorXd& parameters() const { return parameters_; }
  /// The unit each parameter is shown in (Model::parameter_display_units()).
  const std::vector<DisplayUnit>& parameter_display_units() const { return parameter_units_; }
  std::optional<std::size_t> FindParameter(std::string_view name) const;

  const std::vector<LinearModelTerm>& mass_terms() const { return mass_terms_; }
  const std::vector<LinearModelTerm>& damping_terms() const { return damping_terms_; }
  const std::vector<LinearModelTerm>& stiffness_terms() const { return stiffness_terms_; }
  /// B, dof x inputs, and C, outputs x dof (no parameters).
  const SparseMatrix& input_matrix() const { return input_matrix_; }
  const SparseMatrix& output_matrix() const { return output_matrix_; }
  /// A closed chain's constraints G q = 0 (M q'' + D q' + K q = B u + G^T lambda), constraints x
  /// dof; no rows for an open chain. Analysed as the bordered system whose inputs are [u; lambda]
  /// and outputs [y; G q] (AssembleLinearSystem): the pencil
  /// [[K + s D + s^2 M, -B, -G^T], [C, 0, 0], [G, 0, 0]].
  const SparseMatrix& constraint_matrix() const { return constraint_matrix_; }
  std::size_t num_constraints() const { return std::size_t(constraint_matrix_.rows()); }

 private:
  friend class LinearModelBuilder;  // modeling/linear_model.cpp fills a LinearModel
  std::string name_, description_, source_, content_hash_;
  std::size_t dof_ = 0, num_inputs_ = 0, num_outputs_ = 0;
  std::vector<std::string> parameter_names_;
  std::vector<DisplayUnit> parameter_units_;
  Eigen::VectorXd parameters_;
  std::vector<LinearModelTerm> mass_terms_, damping_terms_, stiffness_terms_;
  SparseMatrix input_matrix_, output_matrix_, constraint_matrix_;
};

/// M, D and K of a linear model at parameter values `parameters` (size
/// model.parameter_names().size()), each with the pattern union of its terms (explicit zeros
/// kept, so that the pattern is the same for every parameter point).
struct LinearMatrices {
  SparseMatrix mass, damping, stiffness;
};
/// Throws UsageError if `parameters` has the wrong size, and ModelError ("file: key[k].factor:
/// text = inf at these parameter values") if a factor is not finite there.
LinearMatrices AssembleLinearMatrices(const LinearModel& model,
                                      const Eigen::Ref<const Eigen::VectorXd>& parameters);

/// Reads a linear model file and its Matrix Market files. Throws ModelError
/// ("file: key: problem") for a bad file: missing key, unreadable or malformed .mtx (named),
/// wrong shapes (M, D, K dof x dof; B dof x inputs; C outputs x dof; outputs == inputs),
/// non-finite entries, unknown symbols in a factor, a file of another kind. ParameterOverrideError
/// for a bad override. (LoadModelFile, modeling/loaded_model.h, reads a file of either kind.)
LinearModel LoadLinearModel(const std::string& path,
                            const std::vector<ParameterOverride>& overrides = {});

/// What `servokit generate` writes: the matrices and the YAML text of a linear model.
struct LinearModelFiles {
  std::string name, description;
  std::vector<std::pair<std::string, double>> parameters;  // name, nominal value
  // Each matrix as terms (matrix, factor text); damping may be empty.
  std::vector<std::pair<SparseMatrix, std::string>> mass, damping, stiffness;
  SparseMatrix input_matrix, output_matrix;
  SparseMatrix constraint_matrix;  // no rows: an open chain
};

/// Writes DIR/NAME.yaml and DIR/NAME.<key>[.<term>].mtx (Matrix Market coordinate real general,
/// %.17g so values read back exactly). Returns the YAML path. Throws UsageError if DIR does not
/// exist or a file cannot be written.
///
/// Details (modeling/linear_model.cpp): <key> is M, D, K, B or C; <term> (1, 2, ...) only when a
/// matrix has several terms. Values are written in the shortest form that reads back to the same
/// double (std::to_chars), which is as exact as %.17g and shorter. A term whose matrix is
/// identical (pattern and bits) to one already written names that file instead of writing it
/// again (the beam's D = beta K and K share NAME.D.mtx). A single term with factor "1" is written
/// as a plain file name. NAME must be letters, digits, _, - and . (not first), else UsageError.
std::string WriteLinearModel(const LinearModelFiles& files, const std::string& directory);

namespace detail {

struct ModelDocument;  // modeling/loader_support.h

/// The reader of linear models, from a parsed document of that kind (LoadModelFile dispatches
/// to it, modeling/loaded_model.cpp). Throws as LoadLinearModel does.
LinearModel BuildLinearModel(const ModelDocument& document,
                             const std::vector<ParameterOverride>& overrides);

}  // namespace detail

}  // namespace servokit
