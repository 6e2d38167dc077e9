#include "integrators/solve_summary.h"

#include <array>
#include <utility>

namespace servokit {
namespace {

constexpr std::array<std::pair<SolveStatus, std::string_view>, 10> kSolveStatusNames{{
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

}  // namespace

std::string_view ToString(SolveStatus status) {
  for (const auto& [key, name] : kSolveStatusNames) {
    if (key == status) return name;
  }
  return "unknown";
}

}  // namespace servokit
