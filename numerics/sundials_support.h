#pragma once
// Everything that talks to SUNDIALS goes through here: RAII owners for the context, serial
// N_Vectors, dense matrices, linear solvers and solver memory, one Eigen view of an N_Vector,
// and one check for return flags. It lives in numerics/, below analysis/ (not in solvers/, where
// it was first placed), because the operating point (analysis) already needs KINSOL, and layers
// only link downwards (docs/development.md, "Layout: the folders are the layers").
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>

#include <Eigen/Dense>
#include <memory>
#include <string>

namespace servokit {

/// Owns a SUNContext (one per solver object; SUNDIALS contexts are not shared across threads).
class SundialsContext {
 public:
  SundialsContext();
  ~SundialsContext();
  SundialsContext(const SundialsContext&) = delete;
  SundialsContext& operator=(const SundialsContext&) = delete;
  operator SUNContext() const { return context_; }  // NOLINT: used where SUNDIALS wants one

 private:
  SUNContext context_ = nullptr;
};

struct NVectorDeleter {
  void operator()(N_Vector vector) const { N_VDestroy(vector); }
};
struct SUNMatrixDeleter {
  void operator()(SUNMatrix matrix) const { SUNMatDestroy(matrix); }
};
struct SUNLinearSolverDeleter {
  void operator()(SUNLinearSolver solver) const { SUNLinSolFree(solver); }
};
using NVectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, NVectorDeleter>;
using SUNMatrixPtr = std::unique_ptr<std::remove_pointer_t<SUNMatrix>, SUNMatrixDeleter>;
using SUNLinearSolverPtr =
    std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, SUNLinearSolverDeleter>;

/// A new serial N_Vector of `size` entries, set to zero.
NVectorPtr MakeSerialVector(Eigen::Index size, SUNContext context);

/// The entries of a serial N_Vector, without copying.
Eigen::Map<Eigen::VectorXd> AsEigen(N_Vector vector);

/// A package's flag-name function: KINGetReturnFlagName, IDAGetReturnFlagName, ...
using SundialsFlagNamer = char* (*)(long int flag);

/// The flag's name as SUNDIALS spells it (e.g. "KIN_LINESEARCH_NONCONV").
std::string SundialsFlagName(SundialsFlagNamer namer, int flag);

/// For set-up calls that must not fail: throws std::runtime_error naming the call and the flag
/// if `flag` is negative (SUNDIALS: negative = failure, positive = information).
void CheckSundialsCall(SundialsFlagNamer namer, int flag, const char* call);

/// For SUNDIALS constructors returning a pointer: throws std::runtime_error if it is null.
void CheckSundialsPointer(const void* pointer, const char* call);

}  // namespace servokit
