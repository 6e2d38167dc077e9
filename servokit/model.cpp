// api::Model: a model file of either kind, loaded once and shared.
#include <memory>
#include <string>
#include <vector>

#include "analysis/parameter_grid.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "modeling/units.h"
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

// A linear model's coordinates or inputs: prefix1, prefix2, ...
std::vector<std::string> Numbered(const char* prefix, std::size_t count) {
  std::vector<std::string> names;
  for (std::size_t i = 1; i <= count; ++i) {
    std::string name = prefix;  // appended, not prefix + ...: GCC 12 -Wrestrict (model.cpp)
    name += std::to_string(i);
    names.push_back(std::move(name));
  }
  return names;
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

std::optional<ValueWithUnit> ParseQuantity(std::string_view text) {
  const std::optional<ParsedQuantity> parsed = ParseQuantityWithUnit(text);
  if (!parsed) return std::nullopt;
  return ValueWithUnit{parsed->value, parsed->unit == DisplayUnit::kDegree, parsed->unit_written};
}

ValueWithUnit InParameterUnit(const Model& model,
                              const std::string& parameter,
                              ValueWithUnit value) {
  const std::size_t index = ParameterIndex(model.parameter_names(), parameter);
  const std::vector<std::string> units = model.parameter_display_units();
  const ParsedQuantity read = InDeclaredUnit(
      ParsedQuantity{value.value, value.degrees ? DisplayUnit::kDegree : DisplayUnit::kSI,
                     value.unit_written},
      units[index] == "deg" ? DisplayUnit::kDegree : DisplayUnit::kSI);
  return ValueWithUnit{read.value, read.unit == DisplayUnit::kDegree, read.unit_written};
}

std::string FormatNumber(double value) { return servokit::FormatNumber(value); }

Model Model::MultibodyFromFile(const std::string& path, const ParameterValues& overrides) {
  return Model(
      std::make_shared<const Loaded>(Loaded{LoadedModel(LoadModel(path, ToOverrides(overrides)))}));
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
std::vector<std::string> Model::parameter_display_units() const {
  std::vector<std::string> units;
  for (const DisplayUnit unit : ToolkitModel(*this).parameter_display_units()) {
    units.emplace_back(ToString(unit));
  }
  return units;
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

std::vector<std::string> Model::coordinate_names() const {
  const servokit::Model* multibody = ToolkitModel(*this).multibody();
  return multibody != nullptr ? multibody->coordinates() : Numbered("q", dof());
}
std::vector<std::string> Model::input_names() const {
  const servokit::Model* multibody = ToolkitModel(*this).multibody();
  return multibody != nullptr ? multibody->inputs() : Numbered("u", num_inputs());
}
std::vector<std::string> Model::output_names() const { return Numbered("y", num_outputs()); }
std::vector<std::string> Model::multiplier_names() const {
  const servokit::Model* multibody = ToolkitModel(*this).multibody();
  std::vector<std::string> names;
  for (std::size_t k = 0; multibody != nullptr && k < multibody->num_constraints(); ++k) {
    names.push_back(MultiplierName(k));
  }
  return names;
}

}  // namespace servokit::api
