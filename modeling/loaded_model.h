#pragma once
// One reader for every model file: it reads and parses the YAML once and dispatches on its
// `kind` key. No `kind` (or `kind: multibody`) is a multibody model (modeling/model.h,
// docs/model-files.md), and so are `kind: lagrangian` (energies, modeling/lagrangian_model.h) and
// `kind: planar-bodies` (modeling/planar_bodies.h), whose M and f are derived; `kind: linear` is a
// large linear model (modeling/linear_model.h).
#include <Eigen/Dense>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "base/vocabulary.h"
#include "modeling/linear_model.h"
#include "modeling/model.h"

namespace servokit {

/// The kinds of model file, by their `kind` value.

/// A model of either kind, as read from a model file. Immutable and thread-shareable, as the
/// model it holds.
class LoadedModel {
 public:
  explicit LoadedModel(Model model) : model_(std::move(model)) {}
  explicit LoadedModel(LinearModel model) : model_(std::move(model)) {}

  ModelKind kind() const {
    return std::holds_alternative<Model>(model_) ? ModelKind::kMultibody : ModelKind::kLinear;
  }
  /// The multibody model, or nullptr when the file was a linear one.
  const Model* multibody() const { return std::get_if<Model>(&model_); }
  /// The linear model, or nullptr when the file was a multibody one.
  const LinearModel* linear() const { return std::get_if<LinearModel>(&model_); }
  /// The model itself, for std::visit.
  const std::variant<Model, LinearModel>& variant() const { return model_; }

  // What both kinds have, as Model and LinearModel define it.
  const std::string& name() const {
    return std::visit([](const auto& model) -> const std::string& { return model.name(); }, model_);
  }
  const std::string& source() const {
    return std::visit([](const auto& model) -> const std::string& { return model.source(); },
                      model_);
  }
  const std::vector<std::string>& parameter_names() const {
    return std::visit(
        [](const auto& model) -> const std::vector<std::string>& {
          return model.parameter_names();
        },
        model_);
  }
  const std::vector<DisplayUnit>& parameter_display_units() const {
    return std::visit(
        [](const auto& model) -> const std::vector<DisplayUnit>& {
          return model.parameter_display_units();
        },
        model_);
  }
  const Eigen::VectorXd& parameters() const {
    return std::visit(
        [](const auto& model) -> const Eigen::VectorXd& { return model.parameters(); }, model_);
  }

 private:
  std::variant<Model, LinearModel> model_;
};

/// Reads the model file at `path` (YAML; a linear model's matrix files are relative to it) and
/// loads the model its `kind` names, with `overrides` applied. Throws ModelError ("file: key:
/// entry: problem") for a file that cannot be read, bad YAML, an unknown kind, and whatever
/// LoadModel or LoadLinearModel report for a bad file of their kind; UsageError for a bad
/// override. Thread-safe: the part that uses GiNaC runs under SymbolicLock
/// (modeling/symbolic_lock.h).
LoadedModel LoadModelFile(const std::string& path,
                          const std::vector<ParameterOverride>& overrides = {});

/// As LoadModelFile, from YAML text; `source` names it in messages, and a linear model's matrix
/// files are relative to the directory of `source`.
LoadedModel LoadModelText(const std::string& yaml_text,
                          const std::string& source,
                          const std::vector<ParameterOverride>& overrides = {});

}  // namespace servokit
