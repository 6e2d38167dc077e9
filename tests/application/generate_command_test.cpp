// `servokit generate chain|beam`: the files it writes load as the models the generators build,
// it prints the model path, and each bad option is one usage error (exit 2) naming the option.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "application/exit_codes.h"
#include "modeling/linear_model.h"
#include "modeling/model_generators.h"
#include "tests/application/run_servokit.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::TemporaryDirectory;

namespace fs = std::filesystem;
using testing::Run;
using testing::RunServokit;

constexpr int kBadInput = static_cast<int>(ExitCode::kBadInput);

bool SameMatrix(const SparseMatrix& a, const SparseMatrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && a.nonZeros() == b.nonZeros() &&
         Eigen::MatrixXd(a) == Eigen::MatrixXd(b);
}

TEST_CASE("generate chain writes the generator's chain and prints the model path", "[reports]") {
  TemporaryDirectory directory(/*create=*/false);  // made by the command, with its parents
  const std::string out = directory / "nested/dir";
  const Run run =
      RunServokit({"generate", "chain", "--masses", "12", "--mass", "0.5", "--stiffness", "40",
                   "--damping", "0.2", "--input-mass", "3", "--output-mass", "12", "--out", out});
  INFO(run.err);
  REQUIRE(run.status == 0);
  CHECK(run.out == (fs::path(out) / "chain_12.yaml").string() + "\n");
  const LinearModel model = LoadLinearModel(fs::path(out) / "chain_12.yaml");
  ChainOptions options;
  options.masses = 12;
  options.mass = 0.5;
  options.stiffness = 40;
  options.damping = 0.2;
  options.input_mass = 3;
  options.output_mass = 12;
  const LinearModelFiles expected = GenerateChain(options);
  CHECK(model.parameters() == Eigen::Vector3d(0.5, 40, 0.2));
  CHECK(SameMatrix(model.mass_terms().at(0).matrix, expected.mass.at(0).first));
  CHECK(SameMatrix(model.stiffness_terms().at(0).matrix, expected.stiffness.at(0).first));
  CHECK(SameMatrix(model.input_matrix(), expected.input_matrix));
  CHECK(model.input_matrix().coeff(2, 0) == 1.0);
  CHECK(SameMatrix(model.output_matrix(), expected.output_matrix));
}

// --output-weights linear: y = sum_i (i/N) q_i, so C is the dense row (1/N, 2/N, ..., 1);
// uniform: every weight 1/N.
TEST_CASE("generate chain --output-weights writes a dense output row", "[reports]") {
  TemporaryDirectory directory(/*create=*/false);
  for (const std::string weights : {"linear", "uniform"}) {
    const Run run = RunServokit({"generate", "chain", "--masses", "8", "--output-weights", weights,
                                 "--out", directory.path(), "--name", weights});
    INFO(run.err);
    REQUIRE(run.status == 0);
    const LinearModel model = LoadLinearModel(directory / (weights + ".yaml"));
    const SparseMatrix& output = model.output_matrix();
    REQUIRE(output.rows() == 1);
    REQUIRE(output.cols() == 8);
    CHECK(output.nonZeros() == 8);
    for (int i = 0; i < 8; ++i) {
      CHECK(output.coeff(0, i) == (weights == "linear" ? (i + 1) / 8.0 : 1.0 / 8.0));
    }
    CHECK_THAT(model.description(), Catch::Contains(weights == "linear" ? "(i/N) q_i" : "mean"));
  }
}

TEST_CASE("generate beam writes the generator's beam under the name asked", "[reports]") {
  TemporaryDirectory directory(/*create=*/false);
  const Run run =
      RunServokit({"generate", "beam", "--elements", "5", "--length", "2", "--hub-inertia", "0.3",
                   "--mass-per-length", "1.5", "--bending-stiffness", "20", "--damping-factor",
                   "0.001", "--out", directory.path(), "--name", "flexible_link"});
  INFO(run.err);
  REQUIRE(run.status == 0);
  CHECK(run.out == directory / "flexible_link.yaml\n");
  const LinearModel model = LoadLinearModel(directory / "flexible_link.yaml");
  CHECK(model.name() == "flexible_link");
  CHECK(model.dof() == 11);
  CHECK(model.parameters() == Eigen::Vector4d(0.3, 1.5, 20, 0.001));
  BeamOptions options;
  options.elements = 5;
  options.length = 2;
  const LinearModelFiles expected = GenerateBeam(options);
  REQUIRE(model.mass_terms().size() == 2);
  CHECK(SameMatrix(model.mass_terms()[1].matrix, expected.mass[1].first));
  CHECK(model.damping_terms().at(0).factor_text == "beta*EI");
  CHECK(SameMatrix(model.output_matrix(), expected.output_matrix));
}

TEST_CASE("generate rejects each bad option with one usage error naming it", "[reports]") {
  TemporaryDirectory directory(/*create=*/false);
  const std::string out = directory.path();
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"generate", "chain", "--masses", "0", "--out", out}, "(--masses)"},
      {{"generate", "chain", "--masses", "3", "--input-mass", "4", "--out", out}, "(--input-mass)"},
      {{"generate", "chain", "--masses", "3", "--mass", "-1", "--out", out}, "(--mass)"},
      {{"generate", "chain", "--masses", "three", "--out", out}, "--masses"},
      {{"generate", "chain", "--out", out}, "--masses"},
      {{"generate", "chain", "--masses", "3"}, "--out"},
      {{"generate", "chain", "--masses", "3", "--output-weights", "quadratic", "--out", out},
       "--output-weights quadratic: expected mass, linear or uniform"},
      {{"generate", "chain", "--masses", "3", "--output-weights", "linear", "--output-mass", "2",
        "--out", out},
       "(--output-mass)"},
      {{"generate", "beam", "--elements", "4", "--length", "0", "--out", out}, "(--length)"},
      {{"generate", "beam", "--elements", "4", "--bending-stiffness", "inf", "--out", out},
       "--bending-stiffness"},
      {{"generate", "beam", "--elements", "4", "--damping-factor", "-1", "--out", out},
       "(--damping-factor)"},
      {{"generate", "beam", "--elements", "4", "--out", out, "--name", "a/b"}, "model name 'a/b'"},
      {{"generate"}, "subcommand"},
  };
  for (const auto& [arguments, expected] : cases) {
    const Run run = RunServokit(arguments);
    INFO(run.err);
    CHECK(run.status == kBadInput);
    CHECK(run.out.empty());
    CHECK_THAT(run.err, Catch::StartsWith("servokit: error: ") && Catch::Contains(expected));
    CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
  }
}

}  // namespace
}  // namespace servokit
