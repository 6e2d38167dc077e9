#include "base/vocabulary.h"

#include <algorithm>
#include <array>
#include <utility>

namespace servokit {
namespace {

template <typename Enum, std::size_t N>
using NameTable = std::array<std::pair<Enum, std::string_view>, N>;

constexpr NameTable<ModelKind, 2> kModelKindNames{{
    {ModelKind::kMultibody, "multibody"},
    {ModelKind::kLinear, "linear"},
}};

constexpr NameTable<Realization, 4> kRealizationNames{{
    {Realization::kIdealOrthogonal, "ideal-orthogonal"},
    {Realization::kNonIdealOrthogonal, "non-ideal-orthogonal"},
    {Realization::kTangential, "tangential"},
    {Realization::kMixed, "mixed-orthogonal-tangential"},
}};

constexpr NameTable<Stability, 5> kStabilityNames{{
    {Stability::kAsymptoticallyStable, "asymptotically-stable"},
    {Stability::kUnstable, "unstable"},
    {Stability::kCritical, "critical"},
    {Stability::kNone, "none"},
    {Stability::kUndetermined, "undetermined"},
}};

constexpr NameTable<SolverMethod, 8> kSolverMethodNames{{
    {SolverMethod::kAuto, "auto"},
    {SolverMethod::kAlgebraic, "algebraic"},
    {SolverMethod::kEuler, "euler"},
    {SolverMethod::kRadau, "radau"},
    {SolverMethod::kBdf, "bdf"},
    {SolverMethod::kNormalForm, "normal-form"},
    {SolverMethod::kStableInversion, "stable-inversion"},
    {SolverMethod::kLinearized, "linearized"},
}};

constexpr NameTable<SolveStatus, 10> kSolveStatusNames{{
    {SolveStatus::kConverged, "converged"},
    {SolveStatus::kNoConvergence, "no-convergence"},
    {SolveStatus::kSingularDecoupling, "singular-decoupling"},
    {SolveStatus::kSingularMass, "singular-mass-matrix"},
    {SolveStatus::kStepSizeTooSmall, "step-size-too-small"},
    {SolveStatus::kTooManySteps, "too-many-steps"},
    {SolveStatus::kIntegratorFailure, "integrator-failure"},
    {SolveStatus::kNotApplicable, "not-applicable"},
    {SolveStatus::kInterrupted, "interrupted"},
    {SolveStatus::kVerificationFailed, "verification-failed"},
}};

constexpr NameTable<SolveSetting, 10> kSolveSettingNames{{
    {SolveSetting::kMethod, "method"},
    {SolveSetting::kForce, "forcing"},
    {SolveSetting::kStartTime, "start time"},
    {SolveSetting::kEndTime, "end time"},
    {SolveSetting::kStep, "step"},
    {SolveSetting::kRelativeTolerance, "relative tolerance"},
    {SolveSetting::kAbsoluteTolerance, "absolute tolerance"},
    {SolveSetting::kSampleTime, "sample time"},
    {SolveSetting::kPreActuation, "pre-actuation"},
    {SolveSetting::kPostActuation, "post-actuation"},
}};

constexpr NameTable<ThresholdEvent, 4> kThresholdEventNames{{
    {ThresholdEvent::kStability, "stability"},
    {ThresholdEvent::kOscillation, "oscillation"},
    {ThresholdEvent::kRealization, "realization"},
    {ThresholdEvent::kStructure, "structure"},
}};

constexpr NameTable<LinearEigenSolver, 3> kLinearEigenSolverNames{{
    {LinearEigenSolver::kAuto, "auto"},
    {LinearEigenSolver::kDense, "dense"},
    {LinearEigenSolver::kArpack, "arpack"},
}};

constexpr NameTable<EigenvalueTarget, 2> kEigenvalueTargetNames{{
    {EigenvalueTarget::kNearest, "nearest"},
    {EigenvalueTarget::kRightmost, "rightmost"},
}};

constexpr NameTable<ReportFormat, 3> kReportFormatNames{{
    {ReportFormat::kText, "text"},
    {ReportFormat::kJson, "json"},
    {ReportFormat::kMarkdown, "md"},
}};

constexpr NameTable<SolveFileFormat, 3> kSolveFileFormatNames{{
    {SolveFileFormat::kCsv, "csv"},
    {SolveFileFormat::kMat, "mat"},
    {SolveFileFormat::kModelica, "modelica"},
}};

constexpr NameTable<SweepFileFormat, 3> kSweepFileFormatNames{{
    {SweepFileFormat::kCsv, "csv"},
    {SweepFileFormat::kHdf5, "hdf5"},
    {SweepFileFormat::kMat, "mat"},
}};

constexpr NameTable<ChainOutputWeights, 3> kChainOutputWeightsNames{{
    {ChainOutputWeights::kMass, "mass"},
    {ChainOutputWeights::kLinear, "linear"},
    {ChainOutputWeights::kUniform, "uniform"},
}};

template <typename Enum, std::size_t N>
std::string_view Lookup(const NameTable<Enum, N>& table, Enum value) {
  for (const auto& [key, name] : table) {
    if (key == value) return name;
  }
  return "unknown";  // a value outside the enum (a cast): never one of its words
}

template <typename Enum, std::size_t N>
std::optional<Enum> ReverseLookup(const NameTable<Enum, N>& table, std::string_view text) {
  for (const auto& [key, name] : table) {
    if (name == text) return key;
  }
  return std::nullopt;
}

template <typename Enum, std::size_t N>
std::size_t LongestName(const NameTable<Enum, N>& table) {
  std::size_t longest = 0;
  for (const auto& entry : table) longest = std::max(longest, entry.second.size());
  return longest;
}

}  // namespace

std::string_view ToString(ModelKind kind) { return Lookup(kModelKindNames, kind); }
std::string_view ToString(Realization realization) {
  return Lookup(kRealizationNames, realization);
}
std::string_view ToString(Stability stability) { return Lookup(kStabilityNames, stability); }
std::string_view ToString(SolverMethod method) { return Lookup(kSolverMethodNames, method); }
std::string_view ToString(SolveStatus status) { return Lookup(kSolveStatusNames, status); }
std::string_view ToString(SolveSetting setting) { return Lookup(kSolveSettingNames, setting); }
std::string_view ToString(ThresholdEvent event) { return Lookup(kThresholdEventNames, event); }
std::string_view ToString(LinearEigenSolver solver) {
  return Lookup(kLinearEigenSolverNames, solver);
}
std::string_view ToString(EigenvalueTarget target) {
  return Lookup(kEigenvalueTargetNames, target);
}
std::string_view ToString(ReportFormat format) { return Lookup(kReportFormatNames, format); }
std::string_view ToString(SolveFileFormat format) { return Lookup(kSolveFileFormatNames, format); }
std::string_view ToString(SweepFileFormat format) { return Lookup(kSweepFileFormatNames, format); }
std::string_view ToString(ChainOutputWeights weights) {
  return Lookup(kChainOutputWeightsNames, weights);
}

std::optional<ModelKind> ModelKindFromString(std::string_view text) {
  return ReverseLookup(kModelKindNames, text);
}
std::optional<Realization> RealizationFromString(std::string_view text) {
  return ReverseLookup(kRealizationNames, text);
}
std::optional<Stability> StabilityFromString(std::string_view text) {
  return ReverseLookup(kStabilityNames, text);
}
std::optional<SolverMethod> SolverMethodFromString(std::string_view text) {
  return ReverseLookup(kSolverMethodNames, text);
}
std::optional<SolveStatus> SolveStatusFromString(std::string_view text) {
  return ReverseLookup(kSolveStatusNames, text);
}
std::optional<ThresholdEvent> ThresholdEventFromString(std::string_view text) {
  return ReverseLookup(kThresholdEventNames, text);
}
std::optional<LinearEigenSolver> LinearEigenSolverFromString(std::string_view text) {
  return ReverseLookup(kLinearEigenSolverNames, text);
}
std::optional<EigenvalueTarget> EigenvalueTargetFromString(std::string_view text) {
  return ReverseLookup(kEigenvalueTargetNames, text);
}
std::optional<ReportFormat> ReportFormatFromString(std::string_view text) {
  return ReverseLookup(kReportFormatNames, text);
}
std::optional<SolveFileFormat> SolveFileFormatFromString(std::string_view text) {
  return ReverseLookup(kSolveFileFormatNames, text);
}
std::optional<SweepFileFormat> SweepFileFormatFromString(std::string_view text) {
  return ReverseLookup(kSweepFileFormatNames, text);
}
std::optional<ChainOutputWeights> ChainOutputWeightsFromString(std::string_view text) {
  return ReverseLookup(kChainOutputWeightsNames, text);
}

std::size_t LongestRealizationName() { return LongestName(kRealizationNames); }
std::size_t LongestStabilityName() { return LongestName(kStabilityNames); }

}  // namespace servokit
