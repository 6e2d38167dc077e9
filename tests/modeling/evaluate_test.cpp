// Threading rule (style: model and workspace, docs/development.md): all threads share one Model,
// each owns a Workspace.
#include <catch2/catch.hpp>
#include <thread>
#include <vector>

#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;

constexpr int kPointsPerThread = 2000;
constexpr unsigned kAllQuantities = (1u << kNumQuantities) - 1;

// Every quantity at kPointsPerThread states, flattened into one list in a fixed order.
std::vector<double> EvaluateMany(const Model& model) {
  Workspace workspace(model);
  std::vector<double> values;
  for (int i = 0; i < kPointsPerThread; ++i) {
    const Eigen::Vector2d q(0.001 * i, -0.002 * i), q_dot(0.5, -0.25 + 0.0001 * i);
    Evaluate(model, workspace, q, q_dot, kAllQuantities);
    for (const Eigen::MatrixXd& matrix :
         {workspace.mass_matrix, workspace.input_matrix, workspace.output_jacobian,
          workspace.forces_position_jacobian, workspace.forces_velocity_jacobian,
          workspace.input_matrix_derivatives[1]}) {
      values.insert(values.end(), matrix.data(), matrix.data() + matrix.size());
    }
    for (const Eigen::VectorXd& vector :
         {workspace.forces, workspace.output, workspace.output_bias}) {
      values.insert(values.end(), vector.data(), vector.data() + vector.size());
    }
  }
  return values;
}

TEST_CASE("two threads evaluating one model with their own workspaces agree", "[models]") {
  const Model model = LoadModel(ModelPath("rotational_arm_tip.yaml"), {{"s", "0.5"}});
  const std::vector<double> expected = EvaluateMany(model);
  std::vector<double> first, second;
  std::thread first_thread([&] { first = EvaluateMany(model); });
  std::thread second_thread([&] { second = EvaluateMany(model); });
  first_thread.join();
  second_thread.join();
  CHECK(first == expected);  // bitwise: the same instructions on the same inputs
  CHECK(second == expected);
}

TEST_CASE("a workspace fits the model it was built for and not a larger one", "[models]") {
  const Model car = LoadModel(ModelPath("mass_on_car.yaml"));
  const Model three_dof = LoadModelFromString(R"(name: three
parameters: {m: 1}
coordinates: [x, y, z]
inputs: [F]
mass_matrix: [[m, 0, 0], [0, m, 0], [0, 0, m]]
forces: [0, 0, 0]
input_matrix: [[1], [0], [0]]
outputs: [x + y + z]
)",
                                              "three.yaml");
  CHECK(Workspace(car).Fits(car));
  CHECK_FALSE(Workspace(car).Fits(three_dof));
  Workspace resized(car);
  resized.parameters.resize(1);
  CHECK_FALSE(resized.Fits(car));
}

}  // namespace
}  // namespace servokit
