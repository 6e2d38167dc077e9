// The C++ first session of README.md (and docs/cpp.md), built against the installed package and
// run by install.consumer, which compares what it prints with the output the README shows
// (tests/install/consumer_test.cmake). tests/docs/test_examples.py checks that the README shows
// this code.
#include <servokit/servokit.h>

#include <cstdio>

namespace sk = servokit::api;

int main() {
  // The mass on a car of the paper's Sect. 3, tilted by 5 degrees (MODELS_DIR: the installed
  // models, share/servokit/models).
  const sk::Model model = sk::Model::FromFile(MODELS_DIR "/mass_on_car.yaml", {{"alpha", "5 deg"}});
  const sk::Analysis analysis = sk::Analyze(model);
  std::printf("relative degree %d, zero dynamics %.6g and %.6g\n", analysis.relative_degree[0],
              analysis.zero_dynamics.eigenvalues[0].real(),
              analysis.zero_dynamics.eigenvalues[1].real());

  sk::OutputTrajectory trajectory;  // rest to rest from 0.5 to 2.5 in 6 s (paper Eq. 65)
  trajectory.y0 = Eigen::VectorXd::Constant(1, 0.5);
  trajectory.yf = Eigen::VectorXd::Constant(1, 2.5);
  trajectory.t0 = 0;
  trajectory.tf = 6;
  sk::SolveOptions options;  // method "auto"
  options.t_end = 10;
  options.sample_time = 0.001;  // u_d every millisecond
  options.verify = true;        // drive the model with u_d and check its output
  const sk::Feedforward feedforward = sk::Solve(model, trajectory, options);
  std::printf("u_d at %zu times, largest |F| %.4g N; output error %.2g m, bound %.2g m\n",
              feedforward.t.size(), feedforward.u.cwiseAbs().maxCoeff(),
              feedforward.summary.verification->max_tracking_error,
              feedforward.summary.verification->bound);
  return feedforward.usable ? 0 : 1;
}
