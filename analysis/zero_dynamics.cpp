#include "analysis/zero_dynamics.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "base/errors.h"
#include "numerics/finite.h"

namespace servokit {

void SortEigenvalues(std::vector<std::complex<double>>& eigenvalues) {
  std::sort(eigenvalues.begin(), eigenvalues.end(),
            [](const std::complex<double>& a, const std::complex<double>& b) {
              if (a.real() != b.real()) return a.real() > b.real();
              return a.imag() > b.imag();
            });
}

namespace {

// |z|. std::abs calls hypot, which guards against overflow and underflow at several times the
// cost of a square root; a sweep asks for some ten magnitudes per eigenvalue. Where the squares
// can neither overflow nor underflow the square root of the sum is as accurate (within an ulp).
double Magnitude(std::complex<double> z) {
  constexpr double kSafeLow = 0x1p-500, kSafeHigh = 0x1p+500;
  const double larger = std::max(std::abs(z.real()), std::abs(z.imag()));
  if (larger < kSafeLow || larger > kSafeHigh) return std::abs(z);
  return std::sqrt(z.real() * z.real() + z.imag() * z.imag());
}

}  // namespace

double SpectrumScale(const std::vector<std::complex<double>>& eigenvalues) {
  double largest = 0.0;
  for (const auto& eigenvalue : eigenvalues) largest = std::max(largest, Magnitude(eigenvalue));
  return largest;
}

namespace {

// A part (real or imaginary) of `eigenvalue` that counts as zero: at most `tolerance` times
// the eigenvalue's own magnitude, or at most the zero floor of its spectrum.
bool PartIsZero(double part,
                std::complex<double> eigenvalue,
                double spectrum_scale,
                double tolerance) {
  return std::abs(part) <=
         std::max(tolerance * Magnitude(eigenvalue), kZeroEigenvalueFloor * spectrum_scale);
}

}  // namespace

AxisSide SideOfImaginaryAxis(std::complex<double> eigenvalue,
                             double spectrum_scale,
                             double imaginary_axis_tolerance) {
  if (PartIsZero(eigenvalue.real(), eigenvalue, spectrum_scale, imaginary_axis_tolerance)) {
    return AxisSide::kOn;
  }
  return eigenvalue.real() > 0.0 ? AxisSide::kRight : AxisSide::kLeft;
}

void CleanRoundOff(std::vector<std::complex<double>>& eigenvalues, double tolerance) {
  const double scale = SpectrumScale(eigenvalues);
  for (auto& eigenvalue : eigenvalues) {
    const std::complex<double> original = eigenvalue;
    if (PartIsZero(original.imag(), original, scale, tolerance)) {
      eigenvalue = {eigenvalue.real(), 0.0};
    }
    if (PartIsZero(original.real(), original, scale, tolerance)) {
      eigenvalue = {0.0, eigenvalue.imag()};
    }
  }
}

int CountRightHalfPlane(const std::vector<std::complex<double>>& eigenvalues,
                        double imaginary_axis_tolerance) {
  const double scale = SpectrumScale(eigenvalues);
  int count = 0;
  for (const auto& eigenvalue : eigenvalues) {
    if (SideOfImaginaryAxis(eigenvalue, scale, imaginary_axis_tolerance) == AxisSide::kRight) {
      ++count;
    }
  }
  return count;
}

Stability ClassifyStability(const std::vector<std::complex<double>>& eigenvalues,
                            double imaginary_axis_tolerance) {
  if (eigenvalues.empty()) return Stability::kNone;
  const double scale = SpectrumScale(eigenvalues);
  bool on_axis = false;
  for (const auto& eigenvalue : eigenvalues) {
    const AxisSide side = SideOfImaginaryAxis(eigenvalue, scale, imaginary_axis_tolerance);
    if (side == AxisSide::kRight) return Stability::kUnstable;
    if (side == AxisSide::kOn) on_axis = true;
  }
  return on_axis ? Stability::kCritical : Stability::kAsymptoticallyStable;
}

Mode ModeOf(std::complex<double> eigenvalue) {
  const double magnitude = Magnitude(eigenvalue);
  if (magnitude == 0.0) return {0.0, 1.0};
  // + 0.0: an undamped mode has damping ratio 0, not -0.
  return {magnitude / (2.0 * std::numbers::pi), -eigenvalue.real() / magnitude + 0.0};
}

std::vector<Mode> OscillatoryModes(const std::vector<std::complex<double>>& eigenvalues,
                                   double imaginary_axis_tolerance) {
  const double scale = SpectrumScale(eigenvalues);
  std::vector<Mode> modes;
  for (const auto& eigenvalue : eigenvalues) {
    if (eigenvalue.imag() <= 0.0 ||
        PartIsZero(eigenvalue.imag(), eigenvalue, scale, imaginary_axis_tolerance)) {
      continue;
    }
    modes.push_back(ModeOf(eigenvalue));
  }
  std::sort(modes.begin(), modes.end(),
            [](const Mode& a, const Mode& b) { return a.frequency_hz < b.frequency_hz; });
  return modes;
}

ZeroDynamics ComputeZeroDynamics(const OutputStructure& structure,
                                 const ClassificationOptions& options) {
  ZeroDynamics result;
  const Eigen::MatrixXd& subspace = structure.zero_dynamics_subspace;
  const Eigen::MatrixXd& A = structure.state_space.state_matrix;
  const Eigen::MatrixXd& B = structure.state_space.input_matrix;
  const Eigen::Index order = subspace.cols();
  if (order > 0) {
    // On V* the input u = F x keeps the state in V*: A V = V X - B W for unique X, W
    // (unique because [V, B] has full column rank: checked by AnalyzeOutputStructure).
    Eigen::MatrixXd basis(A.rows(), order + B.cols());
    basis << subspace, -B;
    // Householder QR without pivoting suffices: [V, B] has full column rank (checked).
    const Eigen::MatrixXd solution = basis.householderQr().solve(A * subspace);
    result.state_matrix = solution.topRows(order);
    if (!AllFinite(result.state_matrix)) {
      // Overflow, not a failure of the eigensolver: say so rather than "did not converge".
      throw NoSolution(
          "the zero dynamics' matrix overflows the range of double at the "
          "operating point (a parameter near the end of the double range?)");
    }
    const Eigen::EigenSolver<Eigen::MatrixXd> eigen(result.state_matrix, false);
    if (eigen.info() != Eigen::Success) {
      throw NoSolution("the eigenvalues of the zero dynamics did not converge");
    }
    for (Eigen::Index i = 0; i < order; ++i) result.eigenvalues.push_back(eigen.eigenvalues()(i));
  } else {
    result.state_matrix.resize(0, 0);
  }
  FinishZeroDynamics(result, options.imaginary_axis_tolerance);
  return result;
}

void FinishZeroDynamicsClass(ZeroDynamicsSpectrum& spectrum, double imaginary_axis_tolerance) {
  CleanRoundOff(spectrum.eigenvalues, imaginary_axis_tolerance);
  SortEigenvalues(spectrum.eigenvalues);
  spectrum.stability = ClassifyStability(spectrum.eigenvalues, imaginary_axis_tolerance);
  spectrum.minimum_phase = spectrum.stability == Stability::kAsymptoticallyStable ||
                           spectrum.stability == Stability::kNone;
  spectrum.modes.clear();
}

void FinishZeroDynamics(ZeroDynamicsSpectrum& spectrum, double imaginary_axis_tolerance) {
  FinishZeroDynamicsClass(spectrum, imaginary_axis_tolerance);
  spectrum.modes = OscillatoryModes(spectrum.eigenvalues, imaginary_axis_tolerance);
}

std::optional<AxisSide> SideWithinBound(std::complex<double> eigenvalue,
                                        double error_bound,
                                        double spectrum_scale,
                                        double imaginary_axis_tolerance) {
  if (std::abs(eigenvalue.real()) > error_bound) {
    return eigenvalue.real() > 0.0 ? AxisSide::kRight : AxisSide::kLeft;
  }
  if (PartIsZero(eigenvalue.real(), eigenvalue, spectrum_scale, imaginary_axis_tolerance)) {
    return AxisSide::kOn;
  }
  return std::nullopt;
}

void FinishZeroDynamicsWithBounds(ZeroDynamicsSpectrum& spectrum,
                                  std::vector<double> error_bounds,
                                  double imaginary_axis_tolerance) {
  assert(error_bounds.size() == spectrum.eigenvalues.size());
  std::vector<std::complex<double>>& eigenvalues = spectrum.eigenvalues;
  const double scale = SpectrumScale(eigenvalues);
  // Clean only the parts that are zero by the tolerance AND within the eigenvalue's accuracy.
  for (std::size_t i = 0; i < eigenvalues.size(); ++i) {
    const std::complex<double> original = eigenvalues[i];
    const auto clean = [&](double part) {
      return std::abs(part) <= error_bounds[i] &&
             PartIsZero(part, original, scale, imaginary_axis_tolerance);
    };
    if (clean(original.imag())) eigenvalues[i] = {eigenvalues[i].real(), 0.0};
    if (clean(original.real())) eigenvalues[i] = {0.0, eigenvalues[i].imag()};
  }
  // Sort the pairs (eigenvalue, bound) as SortEigenvalues sorts the eigenvalues.
  std::vector<std::size_t> order(eigenvalues.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (eigenvalues[a].real() != eigenvalues[b].real()) {
      return eigenvalues[a].real() > eigenvalues[b].real();
    }
    return eigenvalues[a].imag() > eigenvalues[b].imag();
  });
  std::vector<std::complex<double>> sorted;
  spectrum.error_bounds.clear();
  for (const std::size_t i : order) {
    sorted.push_back(eigenvalues[i]);
    spectrum.error_bounds.push_back(error_bounds[i]);
  }
  eigenvalues = std::move(sorted);

  spectrum.stability_note.clear();
  if (eigenvalues.empty()) {
    spectrum.stability = Stability::kNone;
  } else {
    bool right = false, on_axis = false;
    std::optional<std::size_t> undecided;
    for (std::size_t i = 0; i < eigenvalues.size(); ++i) {
      const std::optional<AxisSide> side = SideWithinBound(eigenvalues[i], spectrum.error_bounds[i],
                                                           scale, imaginary_axis_tolerance);
      if (!side) {
        if (!undecided) undecided = i;
      } else if (*side == AxisSide::kRight) {
        right = true;
      } else if (*side == AxisSide::kOn) {
        on_axis = true;
      }
    }
    if (right) {
      spectrum.stability = Stability::kUnstable;
    } else if (undecided) {
      spectrum.stability = Stability::kUndetermined;
      const std::size_t i = *undecided;
      char buffer[256];
      std::snprintf(buffer, sizeof buffer,
                    "undetermined at this precision: zero %zu, lambda = %.6g%+.6gi, has "
                    "|Re lambda| = %.3g within its error bound %.3g (|damping ratio| %.3g above "
                    "the axis tolerance %.3g)",
                    i + 1, eigenvalues[i].real(), eigenvalues[i].imag(),
                    std::abs(eigenvalues[i].real()), spectrum.error_bounds[i],
                    std::abs(ModeOf(eigenvalues[i]).damping_ratio), imaginary_axis_tolerance);
      spectrum.stability_note = buffer;
    } else {
      spectrum.stability = on_axis ? Stability::kCritical : Stability::kAsymptoticallyStable;
    }
  }
  spectrum.minimum_phase = spectrum.stability == Stability::kAsymptoticallyStable ||
                           spectrum.stability == Stability::kNone;
  spectrum.modes = OscillatoryModes(eigenvalues, imaginary_axis_tolerance);
}

std::vector<std::complex<double>> InvariantZeros(const Linearization& linearization,
                                                 const ClassificationOptions& options) {
  // Rosenbrock pencil in first-order form, unknowns (dq, dv, du):
  //   [ 0  I  0 ]       [ I 0 0 ]
  //   [-K -D  B ] - s * [ 0 M 0 ],   its finite eigenvalues are the invariant zeros.
  //   [ H  0  0 ]       [ 0 0 0 ]
  const Eigen::Index dof = linearization.dof();
  const Eigen::Index inputs = linearization.num_inputs();
  const Eigen::Index size = 2 * dof + inputs;
  Eigen::MatrixXd pencil_a = Eigen::MatrixXd::Zero(size, size);
  Eigen::MatrixXd pencil_e = Eigen::MatrixXd::Zero(size, size);
  pencil_a.block(0, dof, dof, dof).setIdentity();
  pencil_a.block(dof, 0, dof, dof) = -linearization.stiffness;
  pencil_a.block(dof, dof, dof, dof) = -linearization.damping;
  pencil_a.block(dof, 2 * dof, dof, inputs) = linearization.input_matrix;
  pencil_a.block(2 * dof, 0, inputs, dof) = linearization.output_jacobian;
  pencil_e.block(0, 0, dof, dof).setIdentity();
  pencil_e.block(dof, dof, dof, dof) = linearization.mass_matrix;

  Eigen::GeneralizedEigenSolver<Eigen::MatrixXd> qz(pencil_a, pencil_e, false);
  if (qz.info() != Eigen::Success) throw NoSolution("QZ of the Rosenbrock pencil did not converge");
  const double infinite_threshold = options.rank_tolerance * pencil_e.norm();
  std::vector<std::complex<double>> zeros;
  for (Eigen::Index i = 0; i < size; ++i) {
    const double beta = qz.betas()(i);
    if (std::abs(beta) <= infinite_threshold) continue;
    zeros.push_back(qz.alphas()(i) / beta);
  }
  CleanRoundOff(zeros, options.imaginary_axis_tolerance);
  SortEigenvalues(zeros);
  return zeros;
}

double EigenvalueDistance(std::vector<std::complex<double>> a,
                          std::vector<std::complex<double>> b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  // Greedy matching: each member of a to the nearest unused member of b.
  double distance = 0.0;
  std::vector<bool> used(b.size(), false);
  for (const auto& x : a) {
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_index = 0;
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (used[j]) continue;
      const double gap = std::abs(x - b[j]) / std::max(1.0, std::abs(x));
      if (gap < best) {
        best = gap;
        best_index = j;
      }
    }
    used[best_index] = true;
    distance = std::max(distance, best);
  }
  return distance;
}

}  // namespace servokit
