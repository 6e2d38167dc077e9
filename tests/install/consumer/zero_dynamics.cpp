// A shared library on servokit's public API (only <servokit/servokit.h> is installed): it
// classifies the shipped mass-on-car model and returns how far its zero dynamics are from the
// closed form m2 sin^2(alpha) s^2 + d s + k = 0 (paper Eq. 36 with y_d'' = 0): at alpha = 30 deg,
// m2 = 2, d = 1, k = 5 that is 0.5 s^2 + s + 5, so s = -1 ± 3i.
#include <servokit/servokit.h>

#include <complex>
#include <cstdio>
#include <string>

extern "C" double ZeroDynamicsError() {
  namespace sk = servokit::api;
  try {
    const sk::Model model =
        sk::Model::FromFile(MODELS_DIR "/mass_on_car.yaml", {{"alpha", "30 deg"}, {"d", "1"}});
    const sk::Analysis analysis = sk::Analyze(model);
    const auto& eigenvalues = analysis.zero_dynamics.eigenvalues;
    if (eigenvalues.size() != 2) return -1.0;
    double error = 0;
    for (const std::complex<double>& eigenvalue : eigenvalues) {
      const std::complex<double> expected(-1.0, eigenvalue.imag() > 0 ? 3.0 : -3.0);
      error = std::max(error, std::abs(eigenvalue - expected));
    }
    std::printf("zero dynamics of %s (%s): %.12g %+.12gi, %.12g %+.12gi\n", model.name().c_str(),
                std::string(sk::ToString(analysis.realization)).c_str(), eigenvalues[0].real(),
                eigenvalues[0].imag(), eigenvalues[1].real(), eigenvalues[1].imag());
    return error;
  } catch (const servokit::Error& error) {
    std::fprintf(stderr, "consumer: %s\n", error.what());
    return -1.0;
  }
}
