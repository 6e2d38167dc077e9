#include "modeling/model_generators.h"

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "base/option_check.h"
#include "modeling/matrix_market.h"

namespace servokit {
namespace {

using Triplet = Eigen::Triplet<double>;

// Largest chain or beam: as many coordinates as a Matrix Market file may have (the beam has
// two per node and the hub angle: 2 elements + 1).
constexpr long kMaxMasses = kMaxMatrixDimension;
constexpr long kMaxElements = (kMaxMatrixDimension - 1) / 2;

// The rules of the physical constants: a mass, a length or a stiffness is > 0; a damping or the
// hub's inertia may vanish.
constexpr const char* kFinitePositive = "must be a finite number > 0";
constexpr const char* kFiniteNonNegative = "must be a finite number >= 0";

SparseMatrix FromTriplets(long rows, long cols, const std::vector<Triplet>& triplets) {
  SparseMatrix matrix(rows, cols);
  matrix.setFromTriplets(triplets.begin(), triplets.end());  // sums the elements' overlaps
  matrix.makeCompressed();
  return matrix;
}

// The fixed-free Laplacian of the chain: 2 on the diagonal, 1 at (N, N), -1 beside it.
SparseMatrix ChainLaplacian(long masses) {
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(3 * masses));
  for (long i = 0; i < masses; ++i) {
    const auto row = static_cast<int>(i);
    triplets.emplace_back(row, row, i + 1 < masses ? 2.0 : 1.0);
    if (i + 1 < masses) {
      triplets.emplace_back(row, row + 1, -1.0);
      triplets.emplace_back(row + 1, row, -1.0);
    }
  }
  return FromTriplets(masses, masses, triplets);
}

SparseMatrix UnitEntry(long rows, long cols, long row, long col, double value = 1.0) {
  return FromTriplets(rows, cols, {Triplet(static_cast<int>(row), static_cast<int>(col), value)});
}

// The beam's coordinates: theta at 0, then (w, w') of node n = 1..N at 2n - 1 and 2n. Node 0 is
// clamped to the hub (w_0 = w_0' = 0) and has no coordinates: -1.
int BeamIndex(long node, int slope) {
  return node == 0 ? -1 : static_cast<int>(2 * node - 1 + slope);
}

// Adds the 4 x 4 element matrix of element e (nodes e, e + 1; local order w_a, w_a', w_b, w_b')
// to the triplets, dropping the clamped node's rows and columns.
void AddElement(long element, const double (&matrix)[4][4], std::vector<Triplet>& triplets) {
  const int index[4] = {BeamIndex(element, 0), BeamIndex(element, 1), BeamIndex(element + 1, 0),
                        BeamIndex(element + 1, 1)};
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {
      if (index[a] >= 0 && index[b] >= 0) triplets.emplace_back(index[a], index[b], matrix[a][b]);
    }
  }
}

// The beam's part of M for rho_a = 1: the consistent Hermite mass matrix of w, the coupling of
// the rigid rotation x theta with the shape functions, and int x^2 dx at (theta, theta).
//
// With xi = (x - x_a)/h the Hermite functions are N1 = 1 - 3xi^2 + 2xi^3, N2 = h(xi - 2xi^2 +
// xi^3), N3 = 3xi^2 - 2xi^3, N4 = h(xi^3 - xi^2); int_0^1 of (N1, N2/h, N3, N4/h) is (1/2, 1/12,
// 1/2, -1/12) and of xi (N1, N2/h, N3, N4/h) is (3/20, 1/30, 7/20, -1/20), so int over the
// element of x N_k dx = h int_0^1 (x_a + h xi) N_k dxi gives the coupling below.
SparseMatrix BeamUnitMass(long elements, double length) {
  const double h = length / static_cast<double>(elements);
  const double scale = h / 420.0;
  const double element_mass[4][4] = {
      {156 * scale, 22 * h * scale, 54 * scale, -13 * h * scale},
      {22 * h * scale, 4 * h * h * scale, 13 * h * scale, -3 * h * h * scale},
      {54 * scale, 13 * h * scale, 156 * scale, -22 * h * scale},
      {-13 * h * scale, -3 * h * h * scale, -22 * h * scale, 4 * h * h * scale}};
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(24 * elements + 1));
  triplets.emplace_back(0, 0, length * length * length / 3.0);
  for (long e = 0; e < elements; ++e) {
    AddElement(e, element_mass, triplets);
    const double x_a = static_cast<double>(e) * length / static_cast<double>(elements);
    const double coupling[4] = {h * (x_a / 2 + 3 * h / 20), h * h * (x_a / 12 + h / 30),
                                h * (x_a / 2 + 7 * h / 20), -h * h * (x_a / 12 + h / 20)};
    const int index[4] = {BeamIndex(e, 0), BeamIndex(e, 1), BeamIndex(e + 1, 0),
                          BeamIndex(e + 1, 1)};
    for (int a = 0; a < 4; ++a) {
      if (index[a] < 0) continue;
      triplets.emplace_back(0, index[a], coupling[a]);
      triplets.emplace_back(index[a], 0, coupling[a]);
    }
  }
  const long dof = 2 * elements + 1;
  return FromTriplets(dof, dof, triplets);
}

// The Euler-Bernoulli element stiffness for EI = 1; theta's row and column stay empty (the
// hub turns freely).
SparseMatrix BeamUnitStiffness(long elements, double length) {
  const double h = length / static_cast<double>(elements);
  const double scale = 1.0 / (h * h * h);
  const double element_stiffness[4][4] = {
      {12 * scale, 6 * h * scale, -12 * scale, 6 * h * scale},
      {6 * h * scale, 4 * h * h * scale, -6 * h * scale, 2 * h * h * scale},
      {-12 * scale, -6 * h * scale, 12 * scale, -6 * h * scale},
      {6 * h * scale, 2 * h * h * scale, -6 * h * scale, 4 * h * h * scale}};
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(16 * elements));
  for (long e = 0; e < elements; ++e) AddElement(e, element_stiffness, triplets);
  const long dof = 2 * elements + 1;
  return FromTriplets(dof, dof, triplets);
}

// The chain's output row C (1 x N).
SparseMatrix ChainOutputRow(const ChainOptions& options) {
  const long n = options.masses;
  std::vector<Triplet> triplets;
  switch (options.output_weights) {
    case ChainOutputWeights::kMass:
      triplets.emplace_back(0, static_cast<int>(options.output_mass - 1), 1.0);
      break;
    case ChainOutputWeights::kLinear:
    case ChainOutputWeights::kUniform:
      triplets.reserve(static_cast<std::size_t>(n));
      for (long i = 0; i < n; ++i) {
        const double weight = options.output_weights == ChainOutputWeights::kLinear
                                  ? static_cast<double>(i + 1) / static_cast<double>(n)
                                  : 1.0 / static_cast<double>(n);
        triplets.emplace_back(0, static_cast<int>(i), weight);
      }
      break;
  }
  return FromTriplets(1, n, triplets);
}

// The output's words in the model's description.
std::string ChainOutputText(const ChainOptions& options) {
  switch (options.output_weights) {
    case ChainOutputWeights::kLinear:
      return "output sum (i/N) q_i over all masses";
    case ChainOutputWeights::kUniform:
      return "output the mean position sum q_i / N";
    case ChainOutputWeights::kMass:
      break;
  }
  return "output the position of mass " + std::to_string(options.output_mass);
}

}  // namespace

void ChainOptions::Validate() const {
  constexpr const char* kOptions = "ChainOptions";
  RequireOption(masses >= 1 && masses <= kMaxMasses, kOptions, "masses", masses,
                "must be from 1 to " + std::to_string(kMaxMasses));
  RequireOption(std::isfinite(mass) && mass > 0.0, kOptions, "mass", mass, kFinitePositive);
  RequireOption(std::isfinite(stiffness) && stiffness > 0.0, kOptions, "stiffness", stiffness,
                kFinitePositive);
  RequireOption(std::isfinite(damping) && damping >= 0.0, kOptions, "damping", damping,
                kFiniteNonNegative);
  RequireOption(input_mass >= 1 && input_mass <= masses, kOptions, "input_mass", input_mass,
                "must be from 1 to masses = " + std::to_string(masses));
  RequireOption(output_mass >= 1 && output_mass <= masses, kOptions, "output_mass", output_mass,
                "must be from 1 to masses = " + std::to_string(masses));
  RequireOption(output_weights == ChainOutputWeights::kMass || output_mass == 1, kOptions,
                "output_mass", output_mass,
                "applies only to the output weights 'mass' (the weights are " +
                    std::string(ToString(output_weights)) + ")");
  RequireOption(!closed || masses >= 3, kOptions, "masses", masses,
                "must be at least 3 to close the chain into a ring");
}

LinearModelFiles GenerateChain(const ChainOptions& options) {
  options.Validate();
  const long n = options.masses;
  LinearModelFiles files;
  files.name = (options.closed ? "ring_" : "chain_") + std::to_string(n);
  files.description = "chain of " + std::to_string(n) + " masses m, springs k and dampers d " +
                      "from the ground to a free end" +
                      (options.closed ? ", closed into a ring by a rigid link from mass N back to "
                                        "mass 1 (q_N = q_1)"
                                      : "") +
                      "; force on mass " + std::to_string(options.input_mass) + ", " +
                      ChainOutputText(options) + " (servokit generate chain)";
  files.parameters = {{"m", options.mass}, {"k", options.stiffness}, {"d", options.damping}};
  SparseMatrix identity(n, n);
  identity.setIdentity();
  identity.makeCompressed();
  const SparseMatrix laplacian = ChainLaplacian(n);
  files.mass = {{identity, "m"}};
  files.damping = {{laplacian, "d"}};
  files.stiffness = {{laplacian, "k"}};
  files.input_matrix = UnitEntry(n, 1, options.input_mass - 1, 0);
  files.output_matrix = ChainOutputRow(options);
  if (options.closed) {
    files.constraint_matrix =
        FromTriplets(1, n, {Triplet(0, int(n - 1), 1.0), Triplet(0, 0, -1.0)});
  }
  return files;
}

void BeamOptions::Validate() const {
  constexpr const char* kOptions = "BeamOptions";
  RequireOption(elements >= 1 && elements <= kMaxElements, kOptions, "elements", elements,
                "must be from 1 to " + std::to_string(kMaxElements));
  RequireOption(std::isfinite(length) && length > 0.0, kOptions, "length", length, kFinitePositive);
  RequireOption(std::isfinite(hub_inertia) && hub_inertia >= 0.0, kOptions, "hub_inertia",
                hub_inertia, kFiniteNonNegative);
  RequireOption(std::isfinite(mass_per_length) && mass_per_length > 0.0, kOptions,
                "mass_per_length", mass_per_length, kFinitePositive);
  RequireOption(std::isfinite(bending_stiffness) && bending_stiffness > 0.0, kOptions,
                "bending_stiffness", bending_stiffness, kFinitePositive);
  RequireOption(std::isfinite(damping_factor) && damping_factor >= 0.0, kOptions, "damping_factor",
                damping_factor, kFiniteNonNegative);
}

LinearModelFiles GenerateBeam(const BeamOptions& options) {
  options.Validate();
  const long n = options.elements;
  const long dof = 2 * n + 1;
  LinearModelFiles files;
  files.name = "beam_" + std::to_string(n);
  files.description = "flexible link of length " + FormatNumber(options.length) + " m on a hub, " +
                      std::to_string(n) + " Euler-Bernoulli elements; torque on the hub, " +
                      "output the tip's displacement L theta + w_N (servokit generate beam)";
  files.parameters = {{"J", options.hub_inertia},
                      {"rho_a", options.mass_per_length},
                      {"EI", options.bending_stiffness},
                      {"beta", options.damping_factor}};
  const SparseMatrix stiffness = BeamUnitStiffness(n, options.length);
  files.mass = {{UnitEntry(dof, dof, 0, 0), "J"}, {BeamUnitMass(n, options.length), "rho_a"}};
  files.damping = {{stiffness, "beta*EI"}};
  files.stiffness = {{stiffness, "EI"}};
  files.input_matrix = UnitEntry(dof, 1, 0, 0);
  std::vector<Triplet> output = {Triplet(0, 0, options.length), Triplet(0, BeamIndex(n, 0), 1.0)};
  files.output_matrix = FromTriplets(1, dof, output);
  return files;
}

}  // namespace servokit
