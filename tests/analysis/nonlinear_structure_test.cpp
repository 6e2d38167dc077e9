// The structure algorithm on the nonlinear model (analysis/nonlinear_structure.h): relative
// degrees with analyze's rank rule, dynamic extensions, and relative degrees that are not
// defined at the operating point. Each expectation is derived by hand in its test.
#include "analysis/nonlinear_structure.h"

#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "base/errors.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

// Paper case 3 (alpha = 0, d = 1): y = x + s, m2 y'' = -k s - d s' (Eq. 38), so u first appears
// in y''' (Eq. 39): relative degree 3, one internal coordinate; no extension.
TEST_CASE("mass on car case 3: relative degree 3, internal order 1", "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}});
  const NonlinearStructure structure = DeriveNonlinearStructure(model);
  CHECK(structure.relative_degree == std::vector<int>{3});
  CHECK(structure.highest_derivative == std::vector<int>{3});
  CHECK_FALSE(structure.extended());
  CHECK(structure.integrators() == 0);
  CHECK(structure.internal_order() == 1);
  CHECK(structure.reference_rank == 1);
}

// Gantry crane: both load accelerations follow the rope tension (rank 1 of 2 everywhere); the
// hoist W, which alone changes the tension at rest, is delayed by two integrators: (4, 4).
TEST_CASE("gantry crane: the summary names the delayed input and the extended degrees",
          "[analysis]") {
  const Model model = LoadModel(ModelPath("gantry_crane.yaml"));
  const NonlinearStructureSummary summary = SummarizeNonlinearStructure(model, {});
  REQUIRE(summary.derived);
  CHECK(summary.relative_degree == std::vector<int>{2, 2});
  CHECK(summary.extended);
  CHECK(summary.delayed_inputs == std::vector<std::string>{"W"});
  CHECK(summary.integrators == 2);
  CHECK(summary.extended_relative_degree == std::vector<int>{4, 4});
  CHECK(summary.internal_order == 0);
  CHECK(summary.defined_at_operating_point);
}

// Double-pendulum crane, output the load's horizontal position: y'' carries F through the
// rope angles (a coefficient ~ sin(phi) that vanishes at rest only), so the relative degree is
// 2 near rest and not defined at rest, where the linearization reads 6.
TEST_CASE("double-pendulum crane: P vanishes at the operating point only", "[analysis]") {
  const Model model = LoadModel(TestDataPath("double_pendulum_crane.yaml"));
  const NonlinearStructureSummary summary = SummarizeNonlinearStructure(model, {});
  REQUIRE(summary.derived);
  CHECK(summary.relative_degree == std::vector<int>{2});
  CHECK_FALSE(summary.defined_at_operating_point);
  CHECK_THAT(summary.note, Catch::Matchers::Contains("P vanishes at the operating point only"));
}

// Two outputs that are the same function of q: the second never adds a constraint that the
// first does not, so the structure algorithm runs out of states.
TEST_CASE("dependent outputs have no left inverse", "[analysis]") {
  const Model model = LoadModelFromString(R"(
name: dependent_outputs
description: two masses, two forces, the same position observed twice
parameters:
  k: 2.0
coordinates: [a, b]
inputs: [u1, u2]
mass_matrix:
  - [1, 0]
  - [0, 1]
forces:
  - k*(a - b)
  - k*(b - a)
input_matrix:
  - [1, 0]
  - [0, 1]
outputs:
  - a
  - 2*a
)",
                                          "dependent outputs");
  CHECK_THROWS_WITH(DeriveNonlinearStructure(model),
                    Catch::Matchers::Contains("do not determine the inputs"));
}

}  // namespace
}  // namespace servokit
