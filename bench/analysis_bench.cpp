// Issue #2 benchmark: time to load and compile each shipped model, and operating-point
// analyses per second (servokit analyze without printing). Goals for the 2-coordinate models:
// load under 100 ms, over 100 000 analyses per second (one thread).
//
// Usage: bench_analysis MODELS_DIR [seconds per measurement]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "modeling/model.h"

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Runs `body` repeatedly for about `budget` seconds; returns calls per second.
template <typename Body>
double Rate(double budget, Body&& body) {
  long calls = 0;
  const auto start = Clock::now();
  double elapsed = 0.0;
  do {
    for (int i = 0; i < 64; ++i) body();
    calls += 64;
    elapsed = SecondsSince(start);
  } while (elapsed < budget);
  return double(calls) / elapsed;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODELS_DIR [seconds]\n", argv[0]);
    return 2;
  }
  const std::string directory = argv[1];
  const double budget = argc > 2 ? std::atof(argv[2]) : 1.0;
  const std::vector<std::string> files = {"mass_on_car.yaml",        "rotational_arm.yaml",
                                          "rotational_arm_tip.yaml", "gantry_crane.yaml",
                                          "mass_spring_chain.yaml",  "acrobot.yaml",
                                          "cart_pendulum.yaml"};
  std::printf("%-26s %4s %12s %18s %18s\n", "model", "dof", "load [ms]", "analyses/s",
              "analyses/s (+QZ)");
  for (const std::string& file : files) {
    const std::string path = directory + "/" + file;
    // Load time: the best of 5, so that a cold disk cache does not count.
    double load_ms = 1e300;
    for (int i = 0; i < 5; ++i) {
      const auto start = Clock::now();
      const servokit::Model model = servokit::LoadModel(path);
      load_ms = std::min(load_ms, 1e3 * SecondsSince(start));
    }
    const servokit::Model model = servokit::LoadModel(path);
    servokit::Workspace workspace(model);
    servokit::ClassificationOptions plain;
    plain.cross_check = false;
    const servokit::ClassificationOptions checked;
    const double rate = Rate(budget, [&] { servokit::Classify(model, workspace, plain); });
    const double rate_checked =
        Rate(budget, [&] { servokit::Classify(model, workspace, checked); });
    std::printf("%-26s %4zu %12.2f %18.0f %18.0f\n", file.c_str(), model.dof(), load_ms, rate,
                rate_checked);
  }
  return 0;
}
