// The structure at infinity and V* found directly for a regular decoupling matrix (the kernel of
// the rows C_i A^k, k < r_i; StructureRoute::kDirect) against Wonham's V* iteration
// (StructureRoute::kIteration), the second method: on every shipped model and the test models,
// at parameter points across their ranges and inside the tolerance bands of their singular
// points, both give the same internal order, the same infinite-zero orders and indices, and
// zero dynamics with the same eigenvalues (to round-off), or both refuse.
#include "analysis/output_structure.h"

#include <catch2/catch.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "modeling/model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

struct Outcome {
  std::optional<OutputStructure> structure;
  std::optional<ZeroDynamics> zero_dynamics;
  std::string refusal;
};

Outcome Analyze(const Linearization& linearization, StructureRoute route) {
  const ClassificationOptions options;
  Outcome outcome;
  try {
    outcome.structure = AnalyzeOutputStructure(linearization, options, route);
    outcome.zero_dynamics = ComputeZeroDynamics(*outcome.structure, options);
  } catch (const NoSolution& refusal) {
    outcome.refusal = refusal.what();
  }
  return outcome;
}

std::string Exact(double value) {
  std::ostringstream text;
  text.precision(17);
  text << value;
  return text.str();
}

// Returns how many points had a regular decoupling matrix (where the routes differ at all).
int CompareRoutes(const std::string& path,
                  const std::string& name_a,
                  const std::vector<double>& values_a,
                  const std::string& name_b,
                  const std::vector<double>& values_b) {
  int regular = 0;
  for (const double a : values_a) {
    for (const double b : values_b) {
      const Model model = LoadModel(path, {{name_a, Exact(a)}, {name_b, Exact(b)}});
      Workspace workspace(model);
      ClassificationOptions options;
      options.cross_check = false;
      Linearization linearization;
      try {
        linearization = Linearize(model, workspace,
                                  FindOperatingPoint(model, workspace, options.operating_point));
      } catch (const NoSolution&) {
        continue;  // no operating point: neither route runs
      }
      INFO(path << " at " << name_a << " = " << a << ", " << name_b << " = " << b);
      const Outcome direct = Analyze(linearization, StructureRoute::kDirect);
      const Outcome iterated = Analyze(linearization, StructureRoute::kIteration);
      REQUIRE(direct.structure.has_value() == iterated.structure.has_value());
      if (!direct.structure) {
        CHECK(direct.refusal == iterated.refusal);
        continue;
      }
      const OutputStructure& x = *direct.structure;
      const OutputStructure& y = *iterated.structure;
      if (x.decoupling_matrix_regular) ++regular;
      CHECK(x.relative_degree == y.relative_degree);
      CHECK(x.infinite_zero_orders == y.infinite_zero_orders);
      CHECK(x.internal_dynamics_order == y.internal_dynamics_order);
      CHECK(x.zero_dynamics_subspace.cols() == y.zero_dynamics_subspace.cols());
      CHECK(x.differentiation_index == y.differentiation_index);
      CHECK(x.projected_index == y.projected_index);
      REQUIRE(direct.zero_dynamics.has_value() == iterated.zero_dynamics.has_value());
      if (!direct.zero_dynamics) {
        CHECK(direct.refusal == iterated.refusal);
        continue;
      }
      CHECK(EigenvalueDistance(direct.zero_dynamics->eigenvalues,
                               iterated.zero_dynamics->eigenvalues) <= 1e-9);
      CHECK(direct.zero_dynamics->stability == iterated.zero_dynamics->stability);
    }
  }
  return regular;
}

TEST_CASE("direct V* agrees with the V* iteration on the shipped models", "[analysis]") {
  // The chain (relative degree 12) and the crane (4, 2) are flat: V* = {0} directly.
  CHECK(CompareRoutes(ModelPath("mass_spring_chain.yaml"), "m", {0.5, 1.0, 2.0, 1e-3}, "k",
                      {50.0, 100.0, 200.0, 1e4}) == 16);
  CHECK(CompareRoutes(ModelPath("gantry_crane.yaml"), "m", {1.0, 5.0, 10.0}, "L0",
                      {0.5, 1.0, 2.0, 5.0}) == 12);
  // Tangential at alpha = 0 (relative degree 3, internal order 1) and near it, where the Markov
  // parameter C A B = sin^2(alpha)-sized crosses the rank tolerance.
  CompareRoutes(ModelPath("mass_on_car.yaml"), "alpha",
                {0.0, 1e-12, 1e-9, 1e-6, 1e-5, 1e-3, 0.0873, 1.0, 1.5707963267948966}, "d",
                {0.0, 1e-12, 1.0, 2.0});
  CompareRoutes(ModelPath("rotational_arm.yaml"), "s", {-2.0, -0.5, 0.0, 0.5, 1.0, 2.0}, "d",
                {0.0, 0.25, 1.0});
  CompareRoutes(ModelPath("three_link_arm.yaml"), "c", {10.0, 50.0, 100.0}, "d", {0.0, 0.25});
}

TEST_CASE("direct V* agrees with the V* iteration on the test models", "[analysis]") {
  // chain_output_x3: relative degree 6, internal order 6 (a kernel of dimension 6, not flat).
  CHECK(CompareRoutes(TestDataPath("chain_output_x3.yaml"), "m", {0.5, 1.0, 1e-4}, "k",
                      {1.0, 100.0, 1e6}) == 9);
  CompareRoutes(TestDataPath("chain_output_x1.yaml"), "m", {0.5, 1.0}, "k", {1.0, 100.0});
  // Singular decoupling matrix: the iteration decides on both routes.
  CHECK(CompareRoutes(TestDataPath("two_input_singular_decoupling.yaml"), "ma", {1.0, 2.0}, "k",
                      {1.0, 3.0}) == 0);
  CompareRoutes(TestDataPath("three_mass_chain_middle_output.yaml"), "m1", {0.5, 1.0}, "k",
                {1.0, 10.0});
  CompareRoutes(TestDataPath("double_pendulum_crane.yaml"), "g", {9.81, 1e-8, 0.0}, "l2",
                {0.5, 2.0});
}

}  // namespace
}  // namespace servokit
