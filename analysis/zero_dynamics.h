#pragma once
// The linearized zero dynamics (paper Sect. 4, Eq. 48): the internal dynamics while the output
// is held at its operating value. Computed two independent ways:
//  1. the normal form: the dynamics on V* (analysis/output_structure.h) with the unique input
//     that keeps y constant. For rank P = m this is Eq. (25) at y_d = const, linearized, in the
//     coordinates of an orthonormal basis of V* (q in ker H, q' in ker H); for tangential and
//     mixed realizations it is the same construction with the output's higher derivatives.
//  2. the invariant zeros of the linearization: the finite generalized eigenvalues of the
//     Rosenbrock pencil [[-K - s D_d - s^2 M, B], [H, 0]] in first-order form, by QZ.
#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/linearization.h"
#include "analysis/options.h"
#include "analysis/output_structure.h"
#include "base/vocabulary.h"

namespace servokit {

/// One oscillatory mode: a complex pair lambda, conj(lambda).
struct Mode {
  double frequency_hz = 0.0;   // undamped natural frequency |lambda| / (2 pi)
  double damping_ratio = 0.0;  // -Re(lambda) / |lambda|
};

/// What the eigenvalues of the zero dynamics say, whichever route computed them (the dense
/// normal form here, the sparse pencil of analysis/linear_zero_dynamics.h, the polynomial of a
/// sweep point): filled by FinishZeroDynamics.
struct ZeroDynamicsSpectrum {
  // Eigenvalues sorted by real part, then imaginary part, both descending.
  std::vector<std::complex<double>> eigenvalues;
  Stability stability = Stability::kNone;
  bool minimum_phase = true;  // asymptotically stable zero dynamics, or none (Isidori 1995)
  std::vector<Mode> modes;    // one per complex pair, ascending frequency
  // Per eigenvalue (same order), a bound on its error |delta lambda| (1/s) where the route
  // computes one (large linear models, FinishZeroDynamicsWithBounds); empty otherwise.
  std::vector<double> error_bounds;
  // Why the stability is what it is when the numbers matter: for kUndetermined the eigenvalue,
  // its real part and its bound; for a structural certificate, the certificate. Else empty.
  std::string stability_note;
};

struct ZeroDynamics : ZeroDynamicsSpectrum {
  // x' = state_matrix x on V*, in the orthonormal basis OutputStructure::zero_dynamics_subspace.
  Eigen::MatrixXd state_matrix;
};

/// The frequency |lambda| / (2 pi) and damping ratio -Re(lambda) / |lambda| of an eigenvalue:
/// the one place this formula is written (modes, eigenvalue tables). A zero eigenvalue has
/// frequency 0 and damping ratio 1 by convention (a pure integrator does not oscillate).
Mode ModeOf(std::complex<double> eigenvalue);

/// Zero dynamics from the normal form (route 1). `structure` comes from the same linearization.
ZeroDynamics ComputeZeroDynamics(const OutputStructure& structure,
                                 const ClassificationOptions& options);

/// Invariant zeros of the linearization by QZ (route 2), sorted as ZeroDynamics::eigenvalues.
/// Generalized eigenvalues with |beta| <= rank_tolerance |pencil| are infinite and dropped.
std::vector<std::complex<double>> InvariantZeros(const Linearization& linearization,
                                                 const ClassificationOptions& options);

/// Below this fraction of the spectrum's largest magnitude an eigenvalue counts as 0 (so on
/// the imaginary axis) whatever its direction: a damping ratio means nothing for an eigenvalue
/// that is round-off, and the eigensolvers leave an exact 0 at about 1e-16 max |lambda|
/// (1e-12 leaves four digits for the eigenvalue's condition). It is a floor, not the band:
/// an eigenvalue above it is judged by its own damping ratio, so that a slow mode beside fast
/// ones keeps its verdict. Relative to the spectrum, so that the verdict does not change with
/// the model's time unit.
inline constexpr double kZeroEigenvalueFloor = 1e-12;

/// Where an eigenvalue lies with respect to the imaginary axis.
enum class AxisSide { kLeft, kOn, kRight };

/// The one test of every verdict on the imaginary axis: `eigenvalue` is on it when its own
/// damping ratio is at most `imaginary_axis_tolerance` (|Re| <= tolerance |lambda|) or when
/// |lambda| <= kZeroEigenvalueFloor * spectrum_scale (spectrum_scale: the largest magnitude of
/// the spectrum it belongs to). Otherwise left or right by the sign of Re.
AxisSide SideOfImaginaryAxis(std::complex<double> eigenvalue,
                             double spectrum_scale,
                             double imaginary_axis_tolerance);

/// The largest |lambda| of a set of eigenvalues (0 for none): their SideOfImaginaryAxis scale.
double SpectrumScale(const std::vector<std::complex<double>>& eigenvalues);

/// How many eigenvalues lie right of the imaginary axis (SideOfImaginaryAxis).
int CountRightHalfPlane(const std::vector<std::complex<double>>& eigenvalues,
                        double imaginary_axis_tolerance);

/// Stability class of a set of eigenvalues: unstable if any lies right of the imaginary axis,
/// critical if none does and some lie on it, asymptotically stable otherwise
/// (SideOfImaginaryAxis; ClassificationOptions::imaginary_axis_tolerance).
Stability ClassifyStability(const std::vector<std::complex<double>>& eigenvalues,
                            double imaginary_axis_tolerance);

/// The oscillatory modes of a set of eigenvalues: one per pair with Im > 0 off the real axis
/// (|Im| above imaginary_axis_tolerance |lambda| and above the zero floor).
std::vector<Mode> OscillatoryModes(const std::vector<std::complex<double>>& eigenvalues,
                                   double imaginary_axis_tolerance);

/// Round-off leaves real eigenvalues with a tiny imaginary part and undamped ones with a tiny
/// real part: a part at most `tolerance` times the eigenvalue's own magnitude, or at most
/// kZeroEigenvalueFloor times the largest magnitude, becomes exactly 0, so that verdicts,
/// orderings and tables are reproducible (the stability class counts such an eigenvalue as on
/// the axis anyway).
void CleanRoundOff(std::vector<std::complex<double>>& eigenvalues, double tolerance);

/// The one finishing step of every route to the zero dynamics: CleanRoundOff and
/// SortEigenvalues on spectrum.eigenvalues, then its stability class (ClassifyStability),
/// minimum phase and modes (OscillatoryModes), all with `imaginary_axis_tolerance`
/// (ClassificationOptions).
void FinishZeroDynamics(ZeroDynamicsSpectrum& spectrum, double imaginary_axis_tolerance);

/// FinishZeroDynamics without the modes (spectrum.modes is left empty): what a sweep point
/// needs, whose tables have no modes, at a fraction of the cost.
void FinishZeroDynamicsClass(ZeroDynamicsSpectrum& spectrum, double imaginary_axis_tolerance);

/// Where an eigenvalue with an error bound lies: kOn also for "on the axis within its bound
/// and with a damping ratio at most the axis tolerance"; nullopt when the bound does not
/// decide (|Re lambda| <= error_bound but the damping ratio is above the tolerance).
std::optional<AxisSide> SideWithinBound(std::complex<double> eigenvalue,
                                        double error_bound,
                                        double spectrum_scale,
                                        double imaginary_axis_tolerance);

/// FinishZeroDynamics for eigenvalues that come with error bounds (`error_bounds[i]` bounds
/// |delta lambda_i| in 1/s, same order as spectrum.eigenvalues): each eigenvalue's side is
/// decided from its own accuracy (SideWithinBound), not from a band. Stability: unstable if one
/// lies surely right; else undetermined if the bound of one does not decide (stability_note
/// names it: "zero 1: Re lambda = 7.3e-15 within its error bound 2.9e-10 ..."); else critical if
/// one is on the axis; else asymptotically stable. Round-off is cleaned only within the bound.
/// The bounds are sorted with the eigenvalues into spectrum.error_bounds.
void FinishZeroDynamicsWithBounds(ZeroDynamicsSpectrum& spectrum,
                                  std::vector<double> error_bounds,
                                  double imaginary_axis_tolerance);

/// Sorts eigenvalues by real part, then imaginary part, both descending (a stable order for
/// tables: the least stable first, the upper member of each pair before the lower).
void SortEigenvalues(std::vector<std::complex<double>>& eigenvalues);

/// The largest distance between matched members of two eigenvalue lists, relative to
/// max(1, |lambda|); infinity if their sizes differ.
double EigenvalueDistance(std::vector<std::complex<double>> a, std::vector<std::complex<double>> b);

}  // namespace servokit
