#pragma once
// The one lock around symbolic work (issue #29). GiNaC is not thread-safe: an expression is a
// reference-counted pointer whose count is not atomic, the numbers 0, 1, -1, ... are objects
// shared by every expression of the process, and symbols take serial numbers from a global
// counter. So two threads that touch any GiNaC objects at once, even unrelated ones, can corrupt
// a count and free an object in use. servokit's models and solvers are shared by threads
// (modeling/model.h; servokit/servokit.h promises it), so all GiNaC work of the process runs under
// this one lock:
//   - every function that does symbolic work takes a SymbolicLock for as long as it holds GiNaC
//     objects: the model loaders (modeling/loaded_model.h), DeriveNonlinearStructure and
//     SummarizeNonlinearStructure, DeriveCharacteristicPolynomial, AlgebraicInverse's
//     constructor and DeriveAlgebraicInverse, ServoConstraintProblem's constructor (its
//     structure checks), and SymbolicModel's own members;
//   - an object that keeps GiNaC objects beyond such a call and may be dropped by any thread
//     (SymbolicModel in every Model, AlgebraicInverse in the solvers' cache) keeps them in a
//     SymbolicPtr, which destroys them under the lock;
//   - code that reads GiNaC objects it is given (Model::symbolic(), NonlinearStructure,
//     AlgebraicInverse::input_formulas()) holds a SymbolicLock while it does.
// Numeric code (Evaluate, Newton, the integrators, sweeps) runs compiled programs and never
// takes it. The lock is recursive, so that a function holding it may call another that takes it.
// Never call out to a caller's code under it (a trajectory function, a stop request): the
// Python module drops models while it holds the GIL, so a callback that took the GIL there
// would deadlock.
#include <memory>
#include <mutex>

namespace servokit {

/// The process-wide mutex of all GiNaC work. Prefer SymbolicLock.
std::recursive_mutex& SymbolicMutex();

/// Holds SymbolicMutex() for its scope.
class SymbolicLock {
 public:
  SymbolicLock() : lock_(SymbolicMutex()) {}

 private:
  std::lock_guard<std::recursive_mutex> lock_;
};

/// Deletes under SymbolicLock: the deleter of objects holding GiNaC expressions that threads
/// share, since the last owner to let go of one may be any thread.
struct SymbolicDelete {
  template <typename T>
  void operator()(T* object) const {
    const SymbolicLock lock;
    delete object;
  }
};

/// Owns an object holding GiNaC expressions and destroys it under SymbolicLock.
template <typename T>
using SymbolicPtr = std::unique_ptr<T, SymbolicDelete>;

}  // namespace servokit
