#include "tests/fuzz/fuzz_inputs.h"

#include <unistd.h>

#include <Eigen/Dense>
#include <filesystem>
#include <fstream>
#include <string>

#include "models/errors.h"
#include "models/linear_model.h"
#include "models/loaded_model.h"
#include "models/matrix_market.h"
#include "models/model.h"

namespace servokit::fuzz {
namespace {

namespace fs = std::filesystem;

// Every quantity a multibody model compiles (models/model.h).
constexpr unsigned kAllQuantities = (1u << kNumQuantities) - 1;

// A private directory for the model file under test and the matrices beside it, made once per
// process and removed at exit.
class WorkDirectory {
 public:
  WorkDirectory() {
    path_ = fs::temp_directory_path() / ("servokit-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(path_);
    // The Matrix Market files a fuzzed linear model may name: those of tests/data/linear.
    for (const auto& entry : fs::directory_iterator(fs::path(SERVOKIT_TEST_DATA_DIR) / "linear")) {
      if (entry.path().extension() == ".mtx") {
        fs::copy_file(entry.path(), path_ / entry.path().filename(),
                      fs::copy_options::overwrite_existing);
      }
    }
  }
  ~WorkDirectory() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  std::string Write(std::string_view bytes) const {
    const fs::path file = path_ / "model.yaml";
    std::ofstream(file, std::ios::binary | std::ios::trunc)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return file.string();
  }

 private:
  fs::path path_;
};

// Evaluates everything the model compiled at one state away from zero, as the analysis would.
void EvaluateOnce(const Model& model) {
  Workspace workspace(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(model.dof()), 0.3);
  const Eigen::VectorXd q_dot =
      Eigen::VectorXd::Constant(static_cast<Eigen::Index>(model.dof()), -0.2);
  Evaluate(model, workspace, q, q_dot, kAllQuantities);
}

}  // namespace

void ReadModelFile(std::string_view bytes) {
  static const WorkDirectory directory;
  const std::string path = directory.Write(bytes);
  // The same reader as `servokit analyze` (application/analyze_command.cpp).
  const LoadedModel model = LoadModelFile(path);
  if (const LinearModel* linear = model.linear()) {
    AssembleLinearMatrices(*linear, linear->parameters());
    return;
  }
  EvaluateOnce(*model.multibody());
}

void ReadExpression(std::string_view bytes) {
  std::string quoted;  // a YAML single-quoted scalar: ' is written ''
  for (const char c : bytes) {
    if (c < 0x20 || c > 0x7e) return;
    quoted += c;
    if (c == '\'') quoted += '\'';
  }
  const std::string text =
      "name: fuzz\n"
      "parameters: {m: 1, k: 5, alpha: 5 deg}\n"
      "coordinates: [x, s]\n"
      "inputs: [F]\n"
      "mass_matrix: [[m + 1, m*cos(alpha)], [m*cos(alpha), m]]\n"
      "forces: [0, '" +
      quoted +
      "']\n"
      "input_matrix: [[1], [0]]\n"
      "outputs: ['x + " +
      quoted + "']\n";
  EvaluateOnce(LoadModelFromString(text, "fuzz.yaml"));
}

void ReadMatrixMarket(std::string_view bytes) { ParseMatrixMarket(bytes, "fuzz.mtx"); }

}  // namespace servokit::fuzz
