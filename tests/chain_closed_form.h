#pragma once
// The closed-form zeros of the chain `servokit generate chain` writes
// (modeling/model_generators.h), the independent reference of the linear-model tests.
#include <complex>
#include <numbers>
#include <vector>

namespace servokit::testing {

/// Zeros of a chain of `masses` masses m between springs k with dampers d in parallel (ground
/// at mass 1's side, free end), force on mass 1, output at mass `output_mass` = j. Holding y = 0
/// leaves the n' = N - j masses beyond j as a fixed-free chain: m λ² + d μ_i λ + k μ_i = 0 with
/// μ_i = 4 sin²((2i - 1)π / (2(2n' + 1))), the eigenvalues of its Laplacian. With d > 0 the
/// transfer numerator (k + d s)^(j - 1) adds j - 1 zeros at -k/d. Order: for i = 1, 2, ... (the
/// slowest first) the root with +√ then -√, then the -k/d ones.
inline std::vector<std::complex<double>> ChainZeros(
    long masses, long output_mass, double m, double k, double d) {
  const long free_masses = masses - output_mass;
  std::vector<std::complex<double>> zeros;
  for (long i = 1; i <= free_masses; ++i) {
    const double angle = double(2 * i - 1) * std::numbers::pi / (2.0 * double(2 * free_masses + 1));
    const double mu = 4.0 * std::sin(angle) * std::sin(angle);
    const std::complex<double> root =
        std::sqrt(std::complex<double>(d * d * mu * mu - 4.0 * m * k * mu, 0.0));
    zeros.push_back((-d * mu + root) / (2.0 * m));
    zeros.push_back((-d * mu - root) / (2.0 * m));
  }
  if (d > 0.0) zeros.insert(zeros.end(), std::size_t(output_mass - 1), -k / d);
  return zeros;
}

}  // namespace servokit::testing
