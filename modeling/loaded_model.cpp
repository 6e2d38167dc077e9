// The model-file reader: one read, one parse, then the builder of the file's kind
// (modeling/model_loader.cpp, modeling/linear_model.cpp). LoadModel and LoadLinearModel are this
// reader for callers that accept one kind only. Reading the file and its YAML runs in parallel;
// building the model is symbolic work (GiNaC parses and derives, also a linear model's parameter
// expressions) and runs under SymbolicLock (modeling/symbolic_lock.h), so that models can be
// loaded from several threads at once.
#include "modeling/loaded_model.h"

#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "modeling/linear_model.h"
#include "modeling/loader_support.h"
#include "modeling/model.h"
#include "modeling/symbolic_lock.h"

namespace servokit {
namespace {

// The document's kind: `kind` absent (or a top level that is no map, which the multibody reader
// reports) is multibody, and so are lagrangian and planar-bodies (the multibody reader tells them
// apart). Throws ModelError "source: kind: unknown kind 'x' (expected linear, multibody,
// lagrangian or planar-bodies)" for any other value.
ModelKind ReadModelKind(const detail::ModelDocument& document) {
  if (!document.root.IsMap()) return ModelKind::kMultibody;
  const YAML::Node kind = std::as_const(document.root)[std::string(detail::kKindKey)];
  if (!kind) return ModelKind::kMultibody;
  if (kind.IsScalar() && kind.Scalar() == detail::kMultibodyKind) return ModelKind::kMultibody;
  if (kind.IsScalar() && kind.Scalar() == detail::kLinearKind) return ModelKind::kLinear;
  if (kind.IsScalar() &&
      (kind.Scalar() == detail::kLagrangianKind || kind.Scalar() == detail::kPlanarBodiesKind)) {
    return ModelKind::kMultibody;
  }
  throw ModelError(
      document.source + ": " + std::string(detail::kKindKey) + ": unknown kind '" +
      (kind.IsScalar() ? kind.Scalar() : std::string("(not a name)")) + "' (expected " +
      std::string(detail::kLinearKind) + ", " + std::string(detail::kMultibodyKind) + ", " +
      std::string(detail::kLagrangianKind) + " or " + std::string(detail::kPlanarBodiesKind) + ")");
}

LoadedModel LoadDocument(const detail::ModelDocument& document,
                         const std::vector<ParameterOverride>& overrides) {
  const SymbolicLock lock;
  switch (ReadModelKind(document)) {
    case ModelKind::kLinear:
      return LoadedModel(detail::BuildLinearModel(document, overrides));
    case ModelKind::kMultibody:
      break;
  }
  return LoadedModel(detail::BuildModel(document, overrides));
}

// LoadModel and LoadModelFromString: a multibody model only.
Model LoadMultibodyDocument(const detail::ModelDocument& document,
                            const std::vector<ParameterOverride>& overrides) {
  if (ReadModelKind(document) == ModelKind::kLinear) {
    throw ModelError(document.source + ": " + std::string(detail::kKindKey) +
                     ": a linear model (Matrix Market matrices), which only the linear analysis "
                     "and its sweep read; this needs a multibody model");
  }
  const SymbolicLock lock;
  return detail::BuildModel(document, overrides);
}

}  // namespace

LoadedModel LoadModelFile(const std::string& path,
                          const std::vector<ParameterOverride>& overrides) {
  return LoadDocument(detail::ReadModelDocument(path), overrides);
}

LoadedModel LoadModelText(const std::string& yaml_text,
                          const std::string& source,
                          const std::vector<ParameterOverride>& overrides) {
  return LoadDocument(detail::ParseModelDocument(yaml_text, source), overrides);
}

Model LoadModel(const std::string& path, const std::vector<ParameterOverride>& overrides) {
  return LoadMultibodyDocument(detail::ReadModelDocument(path), overrides);
}

Model LoadModelFromString(const std::string& yaml_text,
                          const std::string& source,
                          const std::vector<ParameterOverride>& overrides) {
  return LoadMultibodyDocument(detail::ParseModelDocument(yaml_text, source), overrides);
}

LinearModel LoadLinearModel(const std::string& path,
                            const std::vector<ParameterOverride>& overrides) {
  const detail::ModelDocument document = detail::ReadModelDocument(path);
  if (ReadModelKind(document) != ModelKind::kLinear) {
    throw ModelError(path + ": " + std::string(detail::kKindKey) + ": expected " +
                     std::string(detail::kLinearKind) +
                     " (this is a multibody model; load it with LoadModel)");
  }
  const SymbolicLock lock;
  return detail::BuildLinearModel(document, overrides);
}

}  // namespace servokit
