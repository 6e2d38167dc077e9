// Classifies the shipped mass-on-car model through the installed servokit::analysis and checks
// the zero dynamics against the closed form m2 sin^2(alpha) s^2 + d s + k = 0 (paper Eq. 36
// with y_d'' = 0): at alpha = 30 deg, m2 = 2, d = 1, k = 5 that is 0.5 s^2 + s + 5, s = -1 ± 3i.
#include <complex>
#include <cstdio>
#include <exception>

#include "analysis/classification.h"
#include "models/errors.h"
#include "models/model.h"

int main() {
  try {
    const servokit::Model model =
        servokit::LoadModel(MODELS_DIR "/mass_on_car.yaml", {{"alpha", "30 deg"}, {"d", "1"}});
    servokit::Workspace workspace(model);
    const servokit::Classification classification = servokit::Classify(model, workspace);
    const auto& eigenvalues = classification.zero_dynamics.eigenvalues;
    if (eigenvalues.size() != 2) {
      std::fprintf(stderr, "consumer: expected 2 zero-dynamics eigenvalues, got %zu\n",
                   eigenvalues.size());
      return 1;
    }
    double error = 0;
    for (const std::complex<double>& eigenvalue : eigenvalues) {
      const std::complex<double> expected(-1.0, eigenvalue.imag() > 0 ? 3.0 : -3.0);
      error = std::max(error, std::abs(eigenvalue - expected));
    }
    std::printf("zero dynamics of %s: %.12g %+.12gi, %.12g %+.12gi (error %.3g)\n",
                model.name().c_str(), eigenvalues[0].real(), eigenvalues[0].imag(),
                eigenvalues[1].real(), eigenvalues[1].imag(), error);
    return error < 1e-9 ? 0 : 1;
  } catch (const servokit::Error& error) {
    std::fprintf(stderr, "consumer: %s\n", error.what());
    return 1;
  }
}
