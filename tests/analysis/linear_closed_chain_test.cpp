// Large linear models with loop constraints G q = 0 (`constraint_matrix`, issue #32): the
// bordered pencil [[K + s D + s^2 M, -B, -G^T], [C, 0, 0], [G, 0, 0]] against the same
// mechanism written without the constraint. The ring of `servokit generate chain --closed` is a
// grounded chain of N masses whose mass N is joined rigidly back to mass 1 (q_N = q_1). Written
// in the N - 1 coordinates r (q = P r, q_N = r_1), it is the open chain P^T M P, P^T D P,
// P^T K P, P^T B, C P (mass 1 carries m twice, the last spring runs from mass N - 1 to mass 1):
// the zeros of both must agree, by the dense route and by ARPACK's shift-invert on the
// bordered Schur complement (this ring showed that a symmetric collocated system's Rayleigh
// refinement took a wrong vector where a zero is also a mode of the structure). A large ring's
// zeros are those of a chain fixed at both ends, in closed form.
#include <Eigen/Dense>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "analysis/linear_analysis.h"
#include "modeling/linear_model.h"
#include "modeling/model_generators.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

constexpr double kMass = 2.0, kStiffness = 3.0, kDamping = 0.05;

LinearModel Ring(long masses, const std::filesystem::path& directory) {
  ChainOptions options;
  options.masses = masses;
  options.mass = kMass;
  options.stiffness = kStiffness;
  options.damping = kDamping;
  options.closed = true;
  return LoadLinearModel(WriteLinearModel(GenerateChain(options), directory.string()));
}

// The ring in its N - 1 independent coordinates: q = P r with q_i = r_i (i < N), q_N = r_1.
LinearSystem WithoutTheConstraint(const LinearModel& ring) {
  const Eigen::Index n = Eigen::Index(ring.dof());
  std::vector<Eigen::Triplet<double>> entries;
  for (Eigen::Index i = 0; i + 1 < n; ++i) entries.emplace_back(int(i), int(i), 1.0);
  entries.emplace_back(int(n - 1), 0, 1.0);
  SparseMatrix basis(n, n - 1);
  basis.setFromTriplets(entries.begin(), entries.end());
  const SparseMatrix transposed = basis.transpose();
  const LinearMatrices matrices = AssembleLinearMatrices(ring, ring.parameters());
  return {SparseMatrix(transposed * matrices.mass * basis),
          SparseMatrix(transposed * matrices.damping * basis),
          SparseMatrix(transposed * matrices.stiffness * basis),
          SparseMatrix(transposed * ring.input_matrix()),
          SparseMatrix(ring.output_matrix() * basis)};
}

// The entry of `zeros` nearest `zero`.
std::vector<std::complex<double>>::iterator Nearest(std::vector<std::complex<double>>& zeros,
                                                    std::complex<double> zero) {
  return std::min_element(zeros.begin(), zeros.end(), [&](const auto& a, const auto& b) {
    return std::abs(a - zero) < std::abs(b - zero);
  });
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

LinearAnalysis Analyze(const LinearSystem& system, const LinearAnalysisOptions& options) {
  LinearZeroDynamicsWorkspace workspace;
  return AnalyzeLinearSystem(system, workspace, options);
}

TEST_CASE("a ring's zeros are those of its chain without the constraint", "[analysis]") {
  testing::TemporaryDirectory directory;
  const LinearModel ring = Ring(40, directory.path());
  REQUIRE(ring.num_constraints() == 1);
  const LinearSystem bordered = AssembleLinearSystem(ring, ring.parameters());
  CHECK(bordered.input_matrix.cols() == 2);   // [B G^T]
  CHECK(bordered.output_matrix.rows() == 2);  // [C; G]

  LinearAnalysisOptions dense;
  dense.zero_dynamics.solver = LinearEigenSolver::kDense;
  const LinearAnalysis loop = Analyze(bordered, dense);
  const LinearAnalysis open = Analyze(WithoutTheConstraint(ring), dense);
  // 2 (N - constraints - outputs) zeros: the loop takes one degree of freedom.
  REQUIRE(loop.zero_dynamics.eigenvalues.size() == 2 * (40 - 1 - 1));
  CHECK(loop.internal_dynamics_order == open.internal_dynamics_order);
  CHECK(loop.zero_dynamics.stability == open.zero_dynamics.stability);
  // Paired by nearness: several zeros share a real part (-d / (2 m)), so no sort pairs them.
  auto expected = open.zero_dynamics.eigenvalues;
  std::vector<std::complex<double>> unmatched = expected;
  REQUIRE(loop.zero_dynamics.eigenvalues.size() == expected.size());
  for (const std::complex<double>& zero : loop.zero_dynamics.eigenvalues) {
    const auto closest = Nearest(unmatched, zero);
    INFO("zero " << zero << " against " << *closest);
    CHECK(std::abs(zero - *closest) <= 1e-10 * std::max(1.0, std::abs(*closest)));
    unmatched.erase(closest);
  }

  // ARPACK's shift-invert on the bordered Schur complement: the six zeros nearest 0.
  LinearAnalysisOptions arpack;
  arpack.zero_dynamics.solver = LinearEigenSolver::kArpack;
  arpack.zero_dynamics.arpack.eigenvalues = 6;
  const LinearAnalysis nearest = Analyze(bordered, arpack);
  REQUIRE(nearest.zero_dynamics.eigenvalues.size() == 6);
  for (const std::complex<double>& zero : nearest.zero_dynamics.eigenvalues) {
    const auto closest = Nearest(expected, zero);
    INFO("ARPACK zero " << zero << ", nearest dense " << *closest);
    CHECK(std::abs(zero - *closest) <= 1e-9 * std::max(1.0, std::abs(*closest)));
  }
}

TEST_CASE("a linear model's constraint matrix is checked on loading", "[modeling]") {
  testing::TemporaryDirectory directory;
  const std::filesystem::path yaml = Ring(5, directory.path()).source();
  // G with the wrong number of columns.
  WriteText(directory / "ring_5.G.mtx",
            "%%MatrixMarket matrix coordinate real general\n1 4 1\n1 1 1\n");
  CHECK_THROWS_WITH(LoadLinearModel(yaml.string()),
                    Catch::Contains("constraint_matrix: expected 5 columns"));
  // As many constraints as coordinates: no degree of freedom left for the output.
  std::string five = "%%MatrixMarket matrix coordinate real general\n5 5 5\n";
  for (int i = 1; i <= 5; ++i) five += std::to_string(i) + " " + std::to_string(i) + " 1\n";
  WriteText(directory / "ring_5.G.mtx", five);
  CHECK_THROWS_WITH(LoadLinearModel(yaml.string()),
                    Catch::Contains("5 constraints for 5 coordinates leave 0 degrees of freedom"));
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// The ring's zero dynamics in closed form: with y = q_1 held at 0 and q_N = q_1, masses 2..N-1
// form a chain fixed at both ends, whose Laplacian has the eigenvalues mu_j = 2 - 2 cos(j pi /
// (N - 1)), j = 1..N-2; with D = d T and K = k T each mode gives m s^2 + d mu_j s + k mu_j = 0.
// ARPACK's ten zeros nearest 0 of a ring of 2000 masses are the five slowest modes' pairs.
TEST_CASE("a ring of 2000 masses has the zeros of a chain fixed at both ends", "[analysis]") {
  testing::TemporaryDirectory directory;
  constexpr long kMasses = 2000;
  const LinearModel ring = Ring(kMasses, directory.path());
  LinearAnalysisOptions options;
  options.zero_dynamics.solver = LinearEigenSolver::kArpack;
  options.zero_dynamics.arpack.eigenvalues = 10;
  const LinearAnalysis analysis = Analyze(AssembleLinearSystem(ring, ring.parameters()), options);
  CHECK(analysis.internal_dynamics_order == 2 * (kMasses - 2));
  REQUIRE(analysis.zero_dynamics.eigenvalues.size() == 10);
  std::vector<std::complex<double>> expected;
  for (int j = 1; j <= 5; ++j) {
    const double mu = 2.0 - 2.0 * std::cos(j * M_PI / double(kMasses - 1));
    const std::complex<double> root = std::sqrt(
        std::complex<double>(kDamping * kDamping * mu * mu - 4.0 * kMass * kStiffness * mu));
    expected.push_back((-kDamping * mu + root) / (2.0 * kMass));
    expected.push_back((-kDamping * mu - root) / (2.0 * kMass));
  }
  for (const std::complex<double>& zero : analysis.zero_dynamics.eigenvalues) {
    const auto closest = Nearest(expected, zero);
    INFO("zero " << zero << ", closed form " << *closest);
    CHECK(std::abs(zero - *closest) <= 1e-9 * std::abs(*closest));
    // The damping, five orders below the frequency, to 1e-6 of itself.
    CHECK(std::abs(zero.real() - closest->real()) <= 1e-6 * std::abs(closest->real()));
  }
}

}  // namespace
}  // namespace servokit
