#include "analysis/types.h"

#include <algorithm>
#include <array>
#include <utility>

namespace servokit {
namespace {

template <typename Enum, std::size_t N>
using NameTable = std::array<std::pair<Enum, std::string_view>, N>;

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

constexpr NameTable<ThresholdEvent, 4> kThresholdEventNames{{
    {ThresholdEvent::kStability, "stability"},
    {ThresholdEvent::kOscillation, "oscillation"},
    {ThresholdEvent::kRealization, "realization"},
    {ThresholdEvent::kStructure, "structure"},
}};

template <typename Enum, std::size_t N>
std::string_view Lookup(const NameTable<Enum, N>& table, Enum value) {
  for (const auto& [key, name] : table) {
    if (key == value) return name;
  }
  return "unknown";
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

std::size_t LongestRealizationName() { return LongestName(kRealizationNames); }
std::size_t LongestStabilityName() { return LongestName(kStabilityNames); }

std::string_view ToString(Realization realization) {
  return Lookup(kRealizationNames, realization);
}
std::string_view ToString(Stability stability) { return Lookup(kStabilityNames, stability); }
std::string_view ToString(SolverMethod method) { return Lookup(kSolverMethodNames, method); }
std::string_view ToString(ThresholdEvent event) { return Lookup(kThresholdEventNames, event); }

std::optional<Realization> RealizationFromString(std::string_view text) {
  return ReverseLookup(kRealizationNames, text);
}
std::optional<Stability> StabilityFromString(std::string_view text) {
  return ReverseLookup(kStabilityNames, text);
}
std::optional<SolverMethod> SolverMethodFromString(std::string_view text) {
  return ReverseLookup(kSolverMethodNames, text);
}
std::optional<ThresholdEvent> ThresholdEventFromString(std::string_view text) {
  return ReverseLookup(kThresholdEventNames, text);
}

}  // namespace servokit
