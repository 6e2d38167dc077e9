// The analyses of a large linear model (analysis/linear_analysis.h) against closed forms and
// against the nonlinear route on the same model.
//
// Chain (GenerateChain; see tests/analysis/linear_zero_dynamics_test.cpp for the zeros): force
// on mass 1, output mass j, M = m I.
//  - P = C M^-1 B = e_j^T e_1 / m: 1/m for j = 1 (ideal orthogonal: B = e_1 is C^T), 0 for j > 1
//    (tangential).
//  - Undamped, u reaches q_j after j - 1 springs: y^(2j) is the first derivative u enters,
//    relative degree 2j, Markov parameter k^(j-1) / m^j; index 2j + 1, projected 2j - 1,
//    internal order 2N - 2j. With dampers each link passes d/m at one derivative less:
//    relative degree j + 1, Markov parameter d^(j-1) / m^j (j >= 2).
//  - j = N undamped: relative degree 2N, flat, algebraic solver.
// The six-mass chain of models/mass_spring_chain.yaml (nonlinear format; free-free, k = 100, force
// on mass 1, output mass 6) has the same structure as the generated grounded chain with output at
// mass 6: Classify and the linear route must give the same class (tangential, relative degree
// 12, index 13, flat, algebraic), though not the same matrices.
#include "analysis/linear_analysis.h"

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "analysis/classification.h"
#include "base/errors.h"
#include "modeling/linear_model.h"
#include "modeling/model.h"
#include "modeling/model_generators.h"
#include "numerics/sparse_structure.h"

namespace servokit {
namespace {

LinearSystem Chain(
    long masses, long output_mass, double damping, double mass = 2.0, double stiffness = 3.0) {
  ChainOptions options;
  options.masses = masses;
  options.output_mass = output_mass;
  options.mass = mass;
  options.stiffness = stiffness;
  options.damping = damping;
  const LinearModelFiles files = GenerateChain(options);
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() /
      ("servokit_la_" + files.name + "_" + std::to_string(std::rand()));
  std::filesystem::create_directories(directory);
  const LinearModel model = LoadLinearModel(WriteLinearModel(files, directory.string()));
  LinearSystem system = AssembleLinearSystem(model, model.parameters());
  std::filesystem::remove_all(directory);
  return system;
}

LinearAnalysis Analyze(const LinearSystem& system) {
  LinearZeroDynamicsWorkspace workspace;
  return AnalyzeLinearSystem(system, workspace);
}

}  // namespace

TEST_CASE("default linear analysis options are valid", "[analysis]") {
  CHECK_NOTHROW(LinearAnalysisOptions{}.Validate());
  LinearAnalysisOptions options;
  options.rank_tolerance = 2.0;
  CHECK_THROWS_WITH(options.Validate(),
                    "LinearAnalysisOptions::rank_tolerance = 2: must be > 0 and < 1");
}

TEST_CASE("undamped chain: relative degree 2j, P and the realization", "[analysis]") {
  for (long output : {1L, 2L, 3L, 5L}) {
    CAPTURE(output);
    const LinearAnalysis analysis = Analyze(Chain(12, output, 0.0));
    REQUIRE(analysis.relative_degrees.relative_degree == std::vector<int>{int(2 * output)});
    // Markov parameter k^(j-1) / m^j, exact up to the sparse solves' round-off.
    CHECK(analysis.relative_degrees.decoupling_matrix(0, 0) ==
          Approx(std::pow(3.0, double(output - 1)) / std::pow(2.0, double(output))).epsilon(1e-12));
    CHECK(analysis.differentiation_index == 2 * output + 1);
    CHECK(analysis.projected_index == 2 * output - 1);
    CHECK(analysis.internal_dynamics_order == 24 - 2 * output);
    CHECK_FALSE(analysis.flat);
    CHECK(analysis.zero_dynamics.stability == Stability::kCritical);
    CHECK(analysis.recommended_solver == SolverMethod::kNormalForm);
    if (output == 1) {
      CHECK(analysis.decoupling.decoupling_matrix(0, 0) == Approx(0.5).epsilon(1e-14));
      CHECK(analysis.decoupling.rank == 1);
      CHECK(analysis.decoupling.realization == Realization::kIdealOrthogonal);
    } else {
      CHECK(analysis.decoupling.decoupling_matrix(0, 0) == 0.0);
      CHECK(analysis.decoupling.rank == 0);
      CHECK(analysis.decoupling.realization == Realization::kTangential);
    }
  }
}

TEST_CASE("damped chain: dampers pass the force one derivative earlier", "[analysis]") {
  for (long output : {2L, 3L, 4L}) {
    CAPTURE(output);
    const LinearAnalysis analysis = Analyze(Chain(12, output, 0.1));
    CHECK(analysis.relative_degrees.relative_degree == std::vector<int>{int(output + 1)});
    CHECK(analysis.relative_degrees.decoupling_matrix(0, 0) ==
          Approx(std::pow(0.1, double(output - 1)) / std::pow(2.0, double(output))).epsilon(1e-12));
    CHECK(analysis.internal_dynamics_order == 24 - (output + 1));
    CHECK(analysis.zero_dynamics.stability == Stability::kAsymptoticallyStable);
  }
}

TEST_CASE("output at the free end of an undamped chain is flat", "[analysis]") {
  const LinearAnalysis analysis = Analyze(Chain(5, 5, 0.0));
  CHECK(analysis.relative_degrees.relative_degree == std::vector<int>{10});
  CHECK(analysis.flat);
  CHECK(analysis.zero_dynamics.eigenvalues.empty());
  CHECK(analysis.zero_dynamics.stability == Stability::kNone);
  CHECK(analysis.recommended_solver == SolverMethod::kAlgebraic);
}

TEST_CASE("the linear route classifies the shipped six-mass chain as Classify does", "[analysis]") {
  const Model model = LoadModel(std::string(SERVOKIT_MODELS_DIR) + "/mass_spring_chain.yaml");
  Workspace workspace(model);
  const Classification nonlinear = Classify(model, workspace);
  const LinearSystem system = Chain(6, 6, 0.0, 1.0, 1.0);
  const LinearAnalysis linear = Analyze(system);
  CHECK(linear.decoupling.realization == nonlinear.decoupling.realization);
  CHECK(linear.decoupling.rank == nonlinear.decoupling.rank);
  CHECK(linear.relative_degrees.relative_degree == nonlinear.structure.relative_degree);
  CHECK(linear.differentiation_index == nonlinear.structure.differentiation_index);
  CHECK(linear.projected_index == nonlinear.structure.projected_index);
  CHECK(linear.internal_dynamics_order == nonlinear.structure.internal_dynamics_order);
  CHECK(linear.flat == nonlinear.flat);
  CHECK(linear.recommended_solver == nonlinear.recommended_solver);
}

TEST_CASE("the reduced linearization has the model's P and norms", "[analysis]") {
  const LinearSystem system = Chain(40, 1, 0.1);
  const Linearization reduced = ReducedLinearization(system, 1e-10);
  CHECK(reduced.dof() <= 3);
  const Eigen::MatrixXd p = reduced.output_jacobian * reduced.mass_inverse * reduced.input_matrix;
  CHECK(p(0, 0) == Approx(0.5).epsilon(1e-14));
  CHECK(reduced.output_jacobian.norm() == Approx(1.0).epsilon(1e-14));
}

TEST_CASE("an output no input reaches is NoSolution", "[analysis]") {
  LinearSystem system = Chain(4, 3, 0.0);
  // Cut the spring between masses 2 and 3: mass 3 no longer feels the force on mass 1.
  system.stiffness.coeffRef(1, 1) = 1.0 * 3.0;
  system.stiffness.coeffRef(2, 2) = 1.0 * 3.0;
  system.stiffness.coeffRef(1, 2) = 0.0;
  system.stiffness.coeffRef(2, 1) = 0.0;
  CHECK_THROWS_AS(Analyze(system), NoSolution);
  CHECK_THROWS_WITH(Analyze(system), Catch::Contains("infinite relative degree"));
}

// ---- singular M of any size (issue #29) ----------------------------------------------------
//
// M = e1 e1^T (one entry, M(0,0) = 1), n coordinates: columns 2..n of M are zero, so M is
// singular whatever its size. Eigen 3.4's SparseLU loops forever on a matrix with fewer than
// n / 20 - 1 stored entries (numerics/sparse_structure.h): at n = 40 it failed cleanly, from
// n = 41 on the analysis never returned.

namespace {

// The chain's K (tridiagonal, grounded at one end), B = e1, C = e1^T, and M = e1 e1^T.
LinearSystem ChainWithPointMass(long masses) {
  LinearSystem system = Chain(masses, 1, 0.1);
  system.mass = SparseMatrix(masses, masses);
  system.mass.insert(0, 0) = 1.0;
  system.mass.makeCompressed();
  return system;
}

}  // namespace

TEST_CASE("a zero column is found whether it stores nothing or only zeros", "[analysis]") {
  SparseMatrix full(3, 3);
  full.insert(0, 0) = 1.0;
  full.insert(2, 1) = -2.0;
  full.insert(1, 2) = 0.5;
  CHECK_FALSE(FindZeroColumn(full).has_value());
  SparseMatrix empty_column = full;
  empty_column.prune([](Eigen::Index, Eigen::Index column, double) { return column != 1; });
  REQUIRE(FindZeroColumn(empty_column).has_value());
  CHECK(*FindZeroColumn(empty_column) == 1);
  SparseMatrix stored_zero = full;
  stored_zero.coeffRef(2, 1) = 0.0;  // the entry stays in the pattern, with the value 0
  REQUIRE(stored_zero.nonZeros() == 3);
  REQUIRE(FindZeroColumn(stored_zero).has_value());
  CHECK(*FindZeroColumn(stored_zero) == 1);
  // The Rosenbrock matrices of the zero dynamics are complex.
  const Eigen::SparseMatrix<std::complex<double>> complex_full = full.cast<std::complex<double>>();
  CHECK_FALSE(FindZeroColumn(complex_full).has_value());
  CHECK(*FindZeroColumn(Eigen::SparseMatrix<std::complex<double>>(3, 3)) == 0);
}

TEST_CASE("a singular mass matrix of any size is NoSolution at once, never a hang", "[analysis]") {
  for (const long masses : {40L, 41L, 200L, 5000L}) {
    INFO(masses << " coordinates");
    const LinearSystem system = ChainWithPointMass(masses);
    const auto start = std::chrono::steady_clock::now();
    // Column 2 is the first zero column of e1 e1^T (1-based, as the message counts).
    CHECK_THROWS_AS(Analyze(system), NoSolution);
    CHECK_THROWS_WITH(Analyze(system), "the mass matrix M is singular: its column 2 is zero");
    // The other entry points factor M the same way.
    CHECK_THROWS_AS(ComputeLinearRelativeDegrees(system, 1e-10), NoSolution);
    CHECK_THROWS_AS(ReducedLinearization(system, 1e-10), NoSolution);
    // A structural test, O(entries): far below a second even at 5000 coordinates (before, the
    // first call never returned).
    CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(1));
  }
}

TEST_CASE("a Rosenbrock matrix with a zero column is NoSolution naming it, never a hang",
          "[analysis]") {
  // K = D = 0 and M = e1 e1^T, B = e1, C = e1^T, n = 200: Q(0) = K = 0 has no row to factor,
  // so the workspace takes the bordered R(0) = [[0, e1], [e1^T, 0]], size 201 with 2 entries;
  // its column 2 (q_2) is zero. Eigen's SparseLU would loop forever on it (20 * 3 < 201).
  LinearSystem system = ChainWithPointMass(200);
  system.stiffness = SparseMatrix(200, 200);
  system.damping = SparseMatrix(200, 200);
  LinearZeroDynamicsWorkspace workspace;
  CHECK_THROWS_AS(workspace.Factorize(system, 0.0), NoSolution);
  CHECK_THROWS_WITH(
      workspace.Factorize(system, 0.0),
      Catch::Contains("singular at the shift s = 0") && Catch::Contains("its column 2 is zero"));
}

}  // namespace servokit
