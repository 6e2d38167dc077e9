#include "numerics/arpack_eigen.h"

#include <algorithm>
#include <arpack.hpp>
#include <cassert>
#include <cmath>
#include <ctime>
#include <string>

#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"

namespace servokit {
namespace {

// The texts of dnaupd.f and dneupd.f (ARPACK-ng 3.8), one table per routine.
struct InfoText {
  int info;
  std::string_view text;
};

constexpr InfoText kNaupdInfo[] = {
    {0, "normal exit"},
    {1, "maximum number of iterations taken; all possible eigenvalues of OP have been found"},
    {3,
     "no shifts could be applied during a cycle of the implicitly restarted Arnoldi "
     "iteration; increase ncv relative to nev"},
    {-1, "N must be positive"},
    {-2, "NEV must be positive"},
    {-3, "NCV-NEV >= 2 and NCV <= N must hold"},
    {-4, "the maximum number of Arnoldi update iterations must be greater than zero"},
    {-5, "WHICH must be one of 'LM', 'SM', 'LR', 'SR', 'LI', 'SI'"},
    {-6, "BMAT must be one of 'I' or 'G'"},
    {-7, "length of private work array WORKL is not sufficient"},
    {-8, "error return from LAPACK eigenvalue calculation"},
    {-9, "starting vector is zero"},
    {-10, "IPARAM(7) must be 1, 2, 3 or 4"},
    {-11, "IPARAM(7) = 1 and BMAT = 'G' are incompatible"},
    {-12, "IPARAM(1) must be equal to 0 or 1"},
    {-9999, "could not build an Arnoldi factorization"},
};

constexpr InfoText kNeupdInfo[] = {
    {0, "normal exit"},
    {1, "the Schur form computed by LAPACK dlahqr could not be reordered by LAPACK dtrsen"},
    {-1, "N must be positive"},
    {-2, "NEV must be positive"},
    {-3, "NCV-NEV >= 2 and NCV <= N must hold"},
    {-5, "WHICH must be one of 'LM', 'SM', 'LR', 'SR', 'LI', 'SI'"},
    {-6, "BMAT must be one of 'I' or 'G'"},
    {-7, "length of private work WORKL array is not sufficient"},
    {-8, "error return from calculation of a real Schur form (LAPACK dlahqr)"},
    {-9, "error return from calculation of eigenvectors (LAPACK dtrevc)"},
    {-10, "IPARAM(7) must be 1, 2, 3 or 4"},
    {-11, "IPARAM(7) = 1 and BMAT = 'G' are incompatible"},
    {-12, "HOWMNY = 'S' not yet implemented"},
    {-13, "HOWMNY must be one of 'A' or 'P' if RVEC = .true."},
    {-14, "DNAUPD did not find any eigenvalues to sufficient accuracy"},
    {-15, "DNEUPD got a different count of converged Ritz values than DNAUPD"},
};

template <std::size_t N>
std::string_view Lookup(const InfoText (&table)[N], int info) {
  for (const InfoText& entry : table) {
    if (entry.info == info) return entry.text;
  }
  return "unknown info code";
}

[[noreturn]] void ThrowArpack(std::string_view routine, int info, const std::string& detail) {
  throw NoSolution("ARPACK " + std::string(routine) + " failed (info = " + std::to_string(info) +
                   "): " + std::string(ArpackInfoMessage(routine, info)) + detail);
}

}  // namespace

std::string_view ArpackInfoMessage(std::string_view routine, int info) {
  return routine == "dneupd" ? Lookup(kNeupdInfo, info) : Lookup(kNaupdInfo, info);
}

void ArpackOptions::Validate() const {
  constexpr const char* kOwner = "ArpackOptions";
  RequireOption(eigenvalues >= 1, kOwner, "eigenvalues", eigenvalues, "must be >= 1");
  RequireOption(basis_size == 0 || basis_size >= eigenvalues + 2, kOwner, "basis_size", basis_size,
                "must be 0 (automatic) or >= eigenvalues + 2 = " + std::to_string(eigenvalues + 2));
  RequireOption(tolerance >= 0.0 && tolerance < 1.0, kOwner, "tolerance", tolerance,
                "must be >= 0 (0: machine precision) and < 1");
  RequireOption(max_iterations >= 1, kOwner, "max_iterations", max_iterations, "must be >= 1");
  RequireOption(time_limit >= 0.0 && std::isfinite(time_limit), kOwner, "time_limit", time_limit,
                "must be a finite number >= 0 (0: no limit)");
}

ArpackResult ArpackEigenvalues(Eigen::Index n,
                               const LinearOperator& apply,
                               ArpackTarget target,
                               const ArpackOptions& options,
                               const std::optional<Eigen::VectorXd>& start) {
  options.Validate();
  RequireOption(options.eigenvalues <= n - 2, "ArpackOptions", "eigenvalues", options.eigenvalues,
                "must be <= n - 2 = " + std::to_string(n - 2) + " for an operator of size " +
                    std::to_string(n));
  const a_int size = static_cast<a_int>(n);
  const a_int nev = options.eigenvalues;
  const a_int ncv = options.basis_size > 0
                        ? std::min(options.basis_size, size)
                        : std::min<a_int>(std::max<a_int>(2 * nev + 10, 30), size);
  const char* which = target == ArpackTarget::kLargestMagnitude ? "LM" : "LR";
  const a_int lworkl = 3 * ncv * ncv + 6 * ncv;
  Eigen::VectorXd resid = Eigen::VectorXd::Zero(n);
  a_int info = 0;
  if (start) {
    assert(start->size() == n);
    resid = *start;
    info = 1;  // use resid as the starting vector
  }
  std::vector<double> basis(std::size_t(n) * std::size_t(ncv));
  std::vector<double> workd(3 * std::size_t(n));
  std::vector<double> workl(static_cast<std::size_t>(lworkl));
  a_int iparam[11] = {};
  a_int ipntr[14] = {};
  iparam[0] = 1;  // exact shifts
  iparam[2] = options.max_iterations;
  iparam[6] = 1;  // mode 1: OP x = lambda x with OP given by `apply`
  a_int ido = 0;
  const std::clock_t started = std::clock();
  long applications = 0;
  for (;;) {
    if (options.time_limit > 0.0 &&
        double(std::clock() - started) / CLOCKS_PER_SEC > options.time_limit) {
      throw NoSolution("ARPACK dnaupd stopped at its time limit of " +
                       FormatSignificant(options.time_limit, 6) + " s CPU after " +
                       std::to_string(applications) + " operator applications, not converged " +
                       "(the shift-invert operator may be too inaccurate for Arnoldi; raise " +
                       "ArpackOptions::time_limit, or make the problem better conditioned)");
    }
    arpack::internal::dnaupd_c(&ido, "I", size, which, nev, options.tolerance, resid.data(), ncv,
                               basis.data(), size, iparam, ipntr, workd.data(), workl.data(),
                               lworkl, &info);
    if (ido == -1 || ido == 1) {
      apply(workd.data() + ipntr[0] - 1, workd.data() + ipntr[1] - 1);
      ++applications;
      continue;
    }
    if (ido == 99) break;
    throw NoSolution("ARPACK dnaupd asked for an operation that mode 1 never asks (ido = " +
                     std::to_string(ido) + ")");
  }
  if (info == 1) {
    ThrowArpack("dnaupd", info,
                " after " + std::to_string(options.max_iterations) + " restarts (" +
                    std::to_string(iparam[4]) + " of " + std::to_string(nev) +
                    " eigenvalues converged; raise max_iterations or the basis size)");
  }
  if (info != 0) ThrowArpack("dnaupd", info, "");

  ArpackResult result;
  result.restarts = iparam[2];
  result.operator_applications = iparam[8];
  result.basis_size = ncv;
  std::vector<a_int> select(static_cast<std::size_t>(ncv), 0);
  std::vector<double> real_parts(static_cast<std::size_t>(nev) + 1);
  std::vector<double> imaginary_parts(static_cast<std::size_t>(nev) + 1);
  std::vector<double> workev(3 * static_cast<std::size_t>(ncv));
  a_int neupd_info = 0;
  // Without eigenvectors (rvec = 0) Z is not referenced and V serves as its placeholder; with
  // them, dneupd may write Z over the first nev + 1 columns of V (dneupd.f, the note on Z).
  const a_int want_vectors = options.ritz_vectors ? 1 : 0;
  arpack::internal::dneupd_c(
      want_vectors, "A", select.data(), real_parts.data(), imaginary_parts.data(), basis.data(),
      size, 0.0, 0.0, workev.data(), "I", size, which, nev, options.tolerance, resid.data(), ncv,
      basis.data(), size, iparam, ipntr, workd.data(), workl.data(), lworkl, &neupd_info);
  if (neupd_info != 0) ThrowArpack("dneupd", neupd_info, "");
  const a_int converged = std::min(iparam[4], nev + 1);
  for (a_int i = 0; i < converged; ++i) {
    result.ritz_values.emplace_back(real_parts[std::size_t(i)], imaginary_parts[std::size_t(i)]);
  }
  result.dimension = n;
  if (options.ritz_vectors) {
    // Column converged (the imaginary part of a last, unpaired complex value) may be needed.
    basis.resize(std::size_t(n) * std::size_t(std::min<a_int>(converged + 1, ncv)));
    result.ritz_vectors = std::move(basis);
  }
  return result;
}

Eigen::VectorXcd RitzVector(const ArpackResult& result, std::size_t index) {
  assert(index < result.ritz_values.size());
  const Eigen::Index n = result.dimension;
  const std::size_t columns =
      result.ritz_vectors.size() / std::size_t(std::max<Eigen::Index>(n, 1));
  assert(columns > index);
  const auto column = [&](std::size_t j) {
    return Eigen::Map<const Eigen::VectorXd>(result.ritz_vectors.data() + j * std::size_t(n), n);
  };
  const std::complex<double> value = result.ritz_values[index];
  if (value.imag() == 0.0) return column(index).cast<std::complex<double>>();
  // The first member of a pair (Im > 0) owns columns index, index + 1; the second (Im < 0,
  // after its partner) is the conjugate of the first's.
  const bool first = value.imag() > 0.0;
  const std::size_t real_column = first ? index : index - 1;
  assert(first || index >= 1);
  if (real_column + 1 >= columns) return column(real_column).cast<std::complex<double>>();
  Eigen::VectorXcd vector(n);
  vector.real() = column(real_column);
  vector.imag() =
      first ? Eigen::VectorXd(column(real_column + 1)) : Eigen::VectorXd(-column(real_column + 1));
  return vector;
}

std::vector<std::complex<double>> ShiftInvertEigenvalues(Eigen::Index n,
                                                         const LinearOperator& shift_invert,
                                                         double shift,
                                                         ArpackTarget target,
                                                         const ArpackOptions& options,
                                                         ArpackResult* details) {
  ArpackResult result = ArpackEigenvalues(n, shift_invert, target, options);
  std::vector<std::complex<double>> eigenvalues;
  for (const auto& ritz_value : result.ritz_values) {
    if (ritz_value == 0.0) continue;  // infinite lambda
    eigenvalues.push_back(shift + 1.0 / ritz_value);
  }
  if (details) *details = std::move(result);
  return eigenvalues;
}

}  // namespace servokit
