// `servokit analyze` on a generated large linear model (issue #6): the JSON keys of
// docs/analyze.md where they apply, the options --eigenvalues, --shift, --eigen-solver, --which,
// and their errors.
//
// Chain of 300 masses (m = k = 1, d = 0.01), force and output at mass 1: P = 1/m = 1, ideal
// orthogonal, relative degree 2, index 3, internal order 2 * 300 - 2 = 598. Holding mass 1 leaves
// the fixed-free chain of n' = 299 masses: zeros lambda^2 + d mu_i lambda + mu_i = 0 with
// mu_i = 4 sin^2((2i - 1) pi / (2 (2n' + 1))) (see tests/analysis/linear_zero_dynamics_test.cpp).
// The 4 nearest 0 are the pairs of i = 1, 2.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "tests/application/run_servokit.h"
#include "tests/chain_closed_form.h"

namespace servokit {
namespace {

using testing::RunServokit;

struct GeneratedChain {
  std::filesystem::path directory;
  std::string yaml;
  ~GeneratedChain() { std::filesystem::remove_all(directory); }
};

// Writes the chain with `servokit generate chain` and returns its YAML path.
void Generate(GeneratedChain& chain) {
  chain.directory =
      std::filesystem::temp_directory_path() /
      ("servokit_analyze_linear_" + std::to_string(::getpid()) + "_" + std::to_string(std::rand()));
  const auto run =
      RunServokit({"generate", "chain", "--masses", "300", "--mass", "1", "--stiffness", "1",
                   "--damping", "0.01", "--out", chain.directory.string()});
  REQUIRE(run.status == 0);
  for (const auto& entry : std::filesystem::directory_iterator(chain.directory)) {
    if (entry.path().extension() == ".yaml") chain.yaml = entry.path().string();
  }
  REQUIRE_FALSE(chain.yaml.empty());
}

}  // namespace

TEST_CASE("analyze prints the JSON object for a large linear model", "[reports]") {
  GeneratedChain chain;
  Generate(chain);
  const auto run = RunServokit({"analyze", chain.yaml, "--format", "json", "--eigenvalues", "4"});
  INFO(run.err);
  REQUIRE(run.status == 0);
  const auto json = nlohmann::json::parse(run.out);
  CHECK(json["dof"] == 300);
  CHECK(json["kind"] == "linear");
  CHECK(json["operating_point"]["u"] == nlohmann::json::array({0.0}));
  CHECK(json["P"][0][0].get<double>() == Approx(1.0).epsilon(1e-13));
  CHECK(json["P_rank"] == 1);
  CHECK(json["realization"] == "ideal-orthogonal");
  CHECK(json["relative_degree"] == nlohmann::json::array({2}));
  CHECK(json["differentiation_index"] == 3);
  CHECK(json["projected_index"] == 1);
  CHECK(json["internal_dynamics_order"] == 598);
  CHECK(json["flat"] == false);
  const auto& zeros = json["zero_dynamics"];
  CHECK(zeros["solver"] == "arpack");  // 300 > 200 coordinates
  CHECK(zeros["complete"] == false);
  CHECK(zeros["zero_count"] == 598);
  REQUIRE(zeros["eigenvalues"].size() == 4);
  // Sorted by real part, then imaginary part, descending: i = 1 (less damped) first.
  // The two slowest pairs of the 299 masses beyond the output (m = k = 1, d = 0.01).
  std::vector<std::complex<double>> expected = testing::ChainZeros(300, 1, 1.0, 1.0, 0.01);
  expected.resize(4);
  for (std::size_t k = 0; k < 4; ++k) {
    const std::complex<double> value(zeros["eigenvalues"][k]["re"].get<double>(),
                                     zeros["eigenvalues"][k]["im"].get<double>());
    // ARPACK to 1e-12 (ArpackOptions::tolerance) on a well-conditioned shift-invert.
    CHECK(std::abs(value - expected[k]) < 1e-10 * std::abs(expected[k]));
  }
  CHECK(zeros["stability"] == "asymptotically-stable");
  CHECK(zeros["modes"].size() == 2);
  CHECK(json["recommended_solver"] == "bdf");
}

TEST_CASE("analyze of a linear model: dense route, text and Markdown", "[reports]") {
  GeneratedChain chain;
  Generate(chain);
  const auto text = RunServokit({"analyze", chain.yaml, "--eigen-solver", "dense"});
  INFO(text.err);
  REQUIRE(text.status == 0);
  CHECK_THAT(text.out, Catch::Contains("realization             ideal-orthogonal"));
  CHECK_THAT(text.out, Catch::Contains("all 598 zeros (dense)"));
  const auto markdown = RunServokit(
      {"analyze", chain.yaml, "--format", "md", "--which", "rightmost", "--eigenvalues", "3"});
  REQUIRE(markdown.status == 0);
  CHECK_THAT(markdown.out, Catch::Contains("| eigenvalues computed | the 3 zeros with largest Re"));
}

TEST_CASE("analyze of a linear model rejects bad eigen options", "[reports]") {
  GeneratedChain chain;
  Generate(chain);
  const auto solver = RunServokit({"analyze", chain.yaml, "--eigen-solver", "qz"});
  CHECK(solver.status == 2);
  CHECK_THAT(solver.err, Catch::Contains("--eigen-solver qz: expected auto, dense or arpack"));
  const auto which = RunServokit({"analyze", chain.yaml, "--which", "largest"});
  CHECK(which.status == 2);
  CHECK_THAT(which.err, Catch::Contains("--which largest: expected nearest or rightmost"));
  const auto count = RunServokit({"analyze", chain.yaml, "--eigenvalues", "0"});
  CHECK(count.status == 2);
  CHECK_THAT(count.err, Catch::Contains("ArpackOptions::eigenvalues = 0: must be >= 1"));
  const auto y0 = RunServokit({"analyze", chain.yaml, "--y0", "1"});
  CHECK(y0.status == 2);
  CHECK_THAT(y0.err, Catch::Contains("--y0: a linear model is analysed at q = 0"));
}

// A chain of 10^5 masses observed through y = sum (i/N) q_i (issue #19): the real parts of its
// slowest zeros (about -2e-11) are far below what double precision resolves at that size, so
// the verdict is `undetermined`, and minimum phase, which follows from it, is undetermined too:
// null in JSON, named so in the text, never "non-minimum phase".
TEST_CASE("an undetermined verdict leaves minimum phase undetermined", "[reports]") {
  GeneratedChain chain;
  chain.directory = std::filesystem::temp_directory_path() /
                    ("servokit_analyze_linear_" + std::to_string(std::rand()));
  REQUIRE(RunServokit({"generate", "chain", "--masses", "100000", "--output-weights", "linear",
                       "--out", chain.directory.string()})
              .status == 0);
  for (const auto& entry : std::filesystem::directory_iterator(chain.directory)) {
    if (entry.path().extension() == ".yaml") chain.yaml = entry.path().string();
  }
  const auto json_run = RunServokit({"analyze", chain.yaml, "--format", "json"});
  INFO(json_run.err);
  REQUIRE(json_run.status == 0);
  const auto json = nlohmann::json::parse(json_run.out);
  CHECK(json["zero_dynamics"]["stability"] == "undetermined");
  CHECK(json["zero_dynamics"]["minimum_phase"].is_null());
  const auto text_run = RunServokit({"analyze", chain.yaml});
  REQUIRE(text_run.status == 0);
  CHECK(text_run.out.find("undetermined, minimum phase undetermined") != std::string::npos);
  CHECK(text_run.out.find("non-minimum phase") == std::string::npos);
}

}  // namespace servokit
