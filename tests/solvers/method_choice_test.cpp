// No dead ends (issue #14): for every shipped model and every class the analysis knows, each
// refusal names methods that do accept the problem, or says that no method of servokit solves
// it and why; auto never picks a method that refuses. The loop covers flat problems (the paper's
// case 4, the six-mass chain, a flexible-joint arm, the gantry and double-pendulum cranes),
// stable, undamped and unstable zero dynamics, orthogonal, tangential and mixed realizations.
#include "solvers/method_choice.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "base/errors.h"
#include "solvers/closed_chain.h"
#include "solvers/inverse_model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

struct Case {
  std::string path;
  std::vector<ParameterOverride> set;
};

const std::vector<SolverMethod> kMethods = {
    SolverMethod::kAlgebraic, SolverMethod::kEuler,      SolverMethod::kRadau,
    SolverMethod::kBdf,       SolverMethod::kNormalForm, SolverMethod::kStableInversion};

std::vector<Case> Cases() {
  return {
      {ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}, {"d", "1"}}},   // case 2: stable
      {ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}, {"d", "0"}}},   // critical
      {ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "1"}}},       // case 3: tangential
      {ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}}},       // case 4: flat
      {ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "-1"}}},      // tangential, unstable
      {ModelPath("mass_on_car.yaml"), {{"alpha", "90 deg"}, {"d", "1"}}},  // ideal orthogonal
      {ModelPath("rotational_arm.yaml"), {{"s", "0.5"}}},                  // stable
      {ModelPath("rotational_arm.yaml"), {}},                              // unstable (s = l)
      {ModelPath("rotational_arm_tip.yaml"), {}},
      {ModelPath("mass_spring_chain.yaml"), {}},  // flat, relative degree 12
      {ModelPath("gantry_crane.yaml"), {}},       // mixed, flat only by a dynamic extension
      {ModelPath("three_link_arm.yaml"), {}},     // unstable, two internal coordinates
      {TestDataPath("two_link_arm_gravity.yaml"), {}},
      {TestDataPath("cart_pole.yaml"), {}},
      {TestDataPath("flexible_joint_arm.yaml"), {}},
      {TestDataPath("double_pendulum_crane.yaml"), {}},
      {TestDataPath("three_mass_chain.yaml"), {}},
      {TestDataPath("chain_output_x3.yaml"), {}},
      {TestDataPath("two_input_singular_decoupling.yaml"), {}},
      {TestDataPath("decoupling_vanishes.yaml"), {}},
  };
}

std::string Name(SolverMethod method) { return std::string(ToString(method)); }

std::vector<SolverMethod> Sorted(std::vector<SolverMethod> methods) {
  std::sort(methods.begin(), methods.end());
  return methods;
}

TEST_CASE(
    "every refusal names a method that fits, or says that none does; auto never refuses "
    "when one fits",
    "[solvers][slow]") {
  for (const Case& test : Cases()) {
    const Model model = LoadModel(test.path, test.set);
    Workspace workspace(model);
    const Classification classification = Classify(model, workspace);
    MethodChooser chooser(model, classification, /*force=*/false);
    std::vector<SolverMethod> accepting;
    for (const SolverMethod method : kMethods) {
      if (chooser.Assess(method).accepts) accepting.push_back(method);
    }
    for (const SolverMethod method : kMethods) {
      INFO(model.name() << " " << (test.set.empty() ? "" : test.set.back().value) << ": "
                        << Name(method));
      if (chooser.Assess(method).accepts) {
        CHECK(chooser.Choose(method).first == method);
        continue;
      }
      try {
        chooser.Choose(method);
        FAIL("a refused method was chosen");
      } catch (const MethodRefused& refusal) {
        const std::string message = refusal.what();
        INFO(message);
        if (accepting.empty()) {
          CHECK_THAT(message, Catch::Contains("no method of servokit solves it"));
          CHECK(refusal.alternatives().empty());
        } else {
          CHECK(Sorted(refusal.alternatives()) == accepting);
          for (const SolverMethod alternative : refusal.alternatives()) {
            CHECK_THAT(message, Catch::Contains(Name(alternative)));
          }
        }
      }
    }
    INFO(model.name() << ": auto");
    if (accepting.empty()) {
      CHECK_THROWS_WITH(chooser.Choose(SolverMethod::kAuto),
                        Catch::Contains("no method of servokit solves this problem"));
    } else {
      const SolverMethod chosen = chooser.Choose(SolverMethod::kAuto).first;
      CHECK(chooser.Assess(chosen).accepts);
      CHECK(chosen != SolverMethod::kEuler);
    }
  }
}

// The double-pendulum crane's P vanishes at rest only: its relative degree is not defined
// there, so no exact inverse passes through it.
TEST_CASE(
    "no method of servokit solves the double-pendulum crane at rest, and the refusal says "
    "why for each",
    "[solvers]") {
  for (const Case& test : {Case{TestDataPath("double_pendulum_crane.yaml"), {}}}) {
    const Model model = LoadModel(test.path, test.set);
    Workspace workspace(model);
    const Classification classification = Classify(model, workspace);
    MethodChooser chooser(model, classification, false);
    INFO(model.name());
    for (const SolverMethod method : kMethods) CHECK_FALSE(chooser.Assess(method).accepts);
    try {
      chooser.Choose(SolverMethod::kAuto);
      FAIL("auto chose a method");
    } catch (const MethodRefused& refusal) {
      for (const SolverMethod method : kMethods) {
        CHECK_THAT(refusal.what(), Catch::Contains(Name(method) + ": "));
      }
    }
  }
}

TEST_CASE("auto's choice runs: no refusal at the start of the solve on any of the models",
          "[solvers][slow]") {
  for (const Case& test : Cases()) {
    const Model model = LoadModel(test.path, test.set);
    Workspace workspace(model);
    const Classification classification = Classify(model, workspace);
    MethodChooser chooser(model, classification, false);
    bool any = false;
    for (const SolverMethod method : kMethods) any = any || chooser.Assess(method).accepts;
    if (!any) continue;
    // A small rest-to-rest move of every output from the operating point, smooth enough for
    // the derivatives the inverse reads.
    const Eigen::VectorXd y0 = classification.operating_point.y;
    const RestToRestTrajectory trajectory(
        y0, y0 + Eigen::VectorXd::Constant(y0.size(), 0.01), 0.0, 2.0,
        RestToRestOrderFor(classification.structure.differentiation_index - 1));
    InverseModelOptions options;
    options.t_end = 3.0;
    INFO(model.name());
    FeedforwardSolution solution;
    CHECK_NOTHROW(solution = SolveInverseModel(model, trajectory, classification, options));
    CHECK(chooser.Assess(solution.method).accepts);
  }
}

TEST_CASE(
    "forced, the forward methods accept unstable zero dynamics; forcing anything else is "
    "an error",
    "[solvers]") {
  const Model arm = LoadModel(ModelPath("rotational_arm.yaml"));
  Workspace workspace(arm);
  const Classification classification = Classify(arm, workspace);
  REQUIRE(classification.zero_dynamics.stability == Stability::kUnstable);
  MethodChooser unforced(arm, classification, false);
  CHECK(unforced.Assess(SolverMethod::kNormalForm).forceable);
  CHECK_FALSE(unforced.Assess(SolverMethod::kNormalForm).accepts);
  MethodChooser forced(arm, classification, true);
  for (const SolverMethod method : {SolverMethod::kNormalForm, SolverMethod::kBdf,
                                    SolverMethod::kRadau, SolverMethod::kEuler}) {
    CHECK(forced.Assess(method).accepts);
  }
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 0.1),
                                        0.0, 1.0);
  InverseModelOptions options;
  options.t_end = 2.0;
  options.force = true;
  options.method = SolverMethod::kStableInversion;
  CHECK_THROWS_AS(SolveInverseModel(arm, trajectory, classification, options), SettingError);
}

// A cart-pole observed at its centre of percussion (tests/data/
// cart_pole_centre_of_percussion.yaml): flat in the linearization, relative degree undefined at
// rest. auto offers no method (Radau IIA, which would take over, stops after 0.6 s), points to
// the method `linearized`, and Radau IIA still runs when asked for by name.
TEST_CASE("relative degree undefined at the operating point: auto offers linearized", "[solvers]") {
  const Model model = LoadModel(TestDataPath("cart_pole_centre_of_percussion.yaml"));
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace);
  REQUIRE(classification.flat);
  MethodChooser chooser(model, classification, false);
  CHECK_THROWS_WITH(chooser.Choose(SolverMethod::kAuto),
                    Catch::Contains("relative degree is not defined at the operating point") &&
                        Catch::Contains("the method `linearized` inverts the linearization"));
  CHECK(chooser.Assess(SolverMethod::kRadau).accepts);
  CHECK(chooser.Assess(SolverMethod::kLinearized).accepts);
  CHECK_FALSE(chooser.Assess(SolverMethod::kAlgebraic).accepts);
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #33: stable inversion asked for on minimum-phase zero dynamics (the paper's rotational
// arm below s/l = 2/3, a chain with a cubic spring) is refused at once, with the reason and the
// causal methods that solve it, instead of widening a window that never settles.
TEST_CASE("stable inversion on asymptotically stable zero dynamics is refused at once",
          "[solvers]") {
  for (const Case& tested : {Case{ModelPath("rotational_arm.yaml"), {{"s", "0.5"}}},
                             Case{TestDataPath("three_mass_chain_cubic_spring.yaml"), {}}}) {
    INFO(tested.path);
    const Model model = LoadModel(tested.path, tested.set);
    Workspace workspace(model);
    const Classification classification = Classify(model, workspace);
    REQUIRE(classification.zero_dynamics.stability == Stability::kAsymptoticallyStable);
    MethodChooser chooser(model, classification, false);
    const MethodVerdict verdict = chooser.Assess(SolverMethod::kStableInversion);
    CHECK_FALSE(verdict.accepts);
    CHECK_FALSE(verdict.forceable);
    CHECK_THAT(verdict.reason, Catch::Contains("asymptotically stable") &&
                                   Catch::Contains("needs no pre-actuation"));
    try {
      chooser.Choose(SolverMethod::kStableInversion);
      FAIL("stable inversion was accepted");
    } catch (const MethodRefused& refused) {
      CHECK_THAT(refused.what(), Catch::Contains("use "));
      CHECK_FALSE(refused.alternatives().empty());
    }
  }
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// The model files of a directory, sorted (the test's order does not depend on the file system).
std::vector<std::string> ModelFiles(const std::string& directory) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(directory)) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Issue #33: the recommendation is what solve does. For every shipped and test model that
// classifies (the deliberately broken fixtures do not), the method analyze recommends (with its
// nonlinear structure derived, as `analyze` does) is accepted by solve, and solves a small
// rest-to-rest move away from the operating point to a usable answer.
TEST_CASE("every model's recommended method is one solve accepts and runs", "[solvers]") {
  std::vector<std::string> files = ModelFiles(ModelPath(""));
  for (const std::string& directory : {TestDataPath(""), TestDataPath("loops")}) {
    for (std::string& file : ModelFiles(directory)) files.push_back(std::move(file));
  }
  int solved = 0;
  for (const std::string& file : files) {
    INFO(file);
    std::optional<Model> model;
    Classification classification;
    try {
      model.emplace(LoadModel(file));
      Workspace workspace(*model);
      classification = Classify(*model, workspace);
    } catch (const Error&) {
      continue;  // a fixture of a load or classification error
    }
    DeriveNonlinearStructure(*model, classification);
    const SolverMethod recommended = classification.recommended_solver;
    INFO("recommended " << ToString(recommended));
    const Eigen::VectorXd y0 = classification.operating_point.y;
    // As smooth as the inverse reads it (solve raises Eq. (65) so).
    const RestToRestTrajectory trajectory(
        y0, (y0.array() + 1e-3).matrix(), 0.0, 1.0,
        RestToRestOrderFor(classification.structure.differentiation_index - 1));
    if (model->num_constraints() == 0) {
      MethodChooser chooser(*model, classification, false);
      CHECK(chooser.Assess(recommended).accepts);
    } else {  // solve chooses on the chain's open form, its loops held as servo constraints
      const LoopsAsServoProblem open = MakeLoopsAsServoProblem(*model, trajectory, classification);
      MethodChooser chooser(*open.model, open.classification, false);
      CHECK(chooser.Assess(recommended).accepts);
    }
    InverseModelOptions options;
    options.method = recommended;
    options.t_end = 1.5;
    const FeedforwardSolution solution =
        SolveInverseModel(*model, trajectory, classification, options);
    INFO(solution.summary.message);
    CHECK(solution.summary.IsUsable());
    ++solved;
  }
  CHECK(solved >= 35);
}

}  // namespace
}  // namespace servokit
