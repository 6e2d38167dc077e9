// api::Model: a model file of either kind, loaded once and shared.
#include <memory>

#include "models/errors.h"
#include "servokit/toolkit_bridge.h"

namespace servokit::api {
namespace {

std::vector<ParameterOverride> ToOverrides(const ParameterValues& values) {
  std::vector<ParameterOverride> overrides;
  for (const auto& [name, value] : values) overrides.push_back({name, value});
  return overrides;
}

template <typename Visitor>
decltype(auto) Visit(const Model& model, Visitor visitor) {
  return std::visit(visitor, ToolkitModel(model).variant());
}

}  // namespace

const Model::Loaded& Unwrap(const Model& model) { return *model.loaded_; }

const servokit::Model& MultibodyModel(const Model& model, const char* operation) {
  const servokit::Model* multibody = ToolkitModel(model).multibody();
  if (multibody == nullptr) {
    throw UsageError(std::string(operation) + ": " + model.source() +
                     " is a linear model (`kind: linear`); this applies to multibody models only");
  }
  return *multibody;
}

Model Model::FromFile(const std::string& path, const ParameterValues& overrides) {
  return Model(std::make_shared<const Loaded>(Loaded{LoadModelFile(path, ToOverrides(overrides))}));
}

Model Model::FromString(const std::string& yaml,
                        const std::string& source,
                        const ParameterValues& overrides) {
  return Model(
      std::make_shared<const Loaded>(Loaded{LoadModelText(yaml, source, ToOverrides(overrides))}));
}

ModelKind Model::kind() const {
  return ToolkitModel(*this).linear() ? ModelKind::kLinear : ModelKind::kMultibody;
}
const std::string& Model::name() const {
  return Visit(*this, [](const auto& model) -> const std::string& { return model.name(); });
}
const std::string& Model::source() const {
  return Visit(*this, [](const auto& model) -> const std::string& { return model.source(); });
}
const std::vector<std::string>& Model::parameter_names() const {
  return Visit(*this, [](const auto& model) -> const std::vector<std::string>& {
    return model.parameter_names();
  });
}
const Eigen::VectorXd& Model::parameters() const {
  return Visit(*this,
               [](const auto& model) -> const Eigen::VectorXd& { return model.parameters(); });
}
std::size_t Model::dof() const {
  return Visit(*this, [](const auto& model) { return model.dof(); });
}
std::size_t Model::num_inputs() const {
  return Visit(*this, [](const auto& model) { return model.num_inputs(); });
}
std::size_t Model::num_outputs() const {
  return Visit(*this, [](const auto& model) { return model.num_outputs(); });
}

}  // namespace servokit::api
