#pragma once
// Shared by the analysis tests: classify a model file with overrides, and closed-form roots.
#include <complex>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit::testing {

inline Classification ClassifyFile(const std::string& path,
                                   const std::vector<ParameterOverride>& overrides = {},
                                   const ClassificationOptions& options = {}) {
  const Model model = LoadModel(path, overrides);
  Workspace workspace(model);
  return Classify(model, workspace, options);
}

/// Roots of a2 x^2 + a1 x + a0 (a2 != 0), sorted as SortEigenvalues does.
inline std::vector<std::complex<double>> QuadraticRoots(double a2, double a1, double a0) {
  const std::complex<double> root = std::sqrt(std::complex<double>(a1 * a1 - 4 * a2 * a0));
  std::vector<std::complex<double>> roots{(-a1 + root) / (2 * a2), (-a1 - root) / (2 * a2)};
  SortEigenvalues(roots);
  return roots;
}

}  // namespace servokit::testing
