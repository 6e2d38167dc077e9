#include "integrators/sundials_integrators.h"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <cvode/cvode_proj.h>
#include <ida/ida.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "base/option_check.h"
#include "numerics/sundials_support.h"

namespace servokit {
namespace {

// SUNDIALS' convention for user callbacks: 0 is success, positive is recoverable (the
// integrator retries with a smaller step), negative is unrecoverable (it stops at once).
constexpr int kCallbackSucceeded = 0;
constexpr int kCallbackRefused = 1;
constexpr int kCallbackThrew = -1;

// Breakpoints closer than this many round-offs of t to each other or to the ends are merged:
// SUNDIALS refuses to start on an interval of a few round-offs (CV_TOO_CLOSE, ARK_TOO_CLOSE),
// and a restart there would change nothing.
constexpr double kBreakpointResolutionInRoundoffs = 1000.0;

std::string AtTime(double t) { return "at t = " + FormatNumber(t) + " s"; }

// SUNDIALS prints its errors to stderr by default; keep the last one for the summary instead.
// Warnings (positive codes, such as "t + h = t") are dropped: the flag that follows says more.
void KeepLastError(int error_code, const char*, const char*, char* message, void* last_error) {
  if (error_code < 0) *static_cast<std::string*>(last_error) = message;
}

// Runs a user callback on behalf of a SUNDIALS C callback. It counts the calls, keeps the
// reason of the last refusal (reported if SUNDIALS then gives up) and catches exceptions,
// which must not unwind through SUNDIALS' C frames; the driver rethrows them once SUNDIALS
// has returned.
class CallbackGuard {
 public:
  // `what` names the function in messages ("the right-hand side").
  explicit CallbackGuard(std::string what) : what_(std::move(what)) {}

  // `evaluate(why)` calls the user's function and returns whether it succeeded. Returns the
  // flag SUNDIALS expects from the callback.
  template <typename Evaluate>
  int Run(double t, Evaluate&& evaluate) noexcept {
    try {
      ++evaluations_;
      why_.clear();
      if (evaluate(why_)) return kCallbackSucceeded;
      refusal_ = why_.empty() ? what_ + " could not be evaluated" : why_;
      refusal_time_ = t;
      return kCallbackRefused;
    } catch (...) {
      exception_ = std::current_exception();
      return kCallbackThrew;
    }
  }

  // Turns a non-finite or mis-sized output of a successful call into a refusal or an error.
  bool AcceptOutput(const Eigen::VectorXd& output, Eigen::Index size, std::string& why) const {
    if (output.size() != size) {
      // A programming error in the callback; writing it into SUNDIALS' vector would corrupt
      // memory.
      throw std::logic_error(what_ + " returned " + std::to_string(output.size()) +
                             " values instead of " + std::to_string(size));
    }
    if (!output.allFinite()) {
      why = what_ + " is not finite";
      return false;
    }
    return true;
  }

  // Evaluations are kept strictly inside the current segment's breakpoints: SUNDIALS evaluates
  // at the segment's end itself (the last stage of the step that lands there, rounded), where
  // a function that jumps must give the value of this segment's side. One ulp is far below
  // the integrator's own resolution in t.
  void SetSegment(double lowest_time, double highest_time) {
    lowest_time_ = lowest_time;
    highest_time_ = highest_time;
  }
  double InsideSegment(double t) const { return std::clamp(t, lowest_time_, highest_time_); }

  void RethrowIfThrown() const {
    if (exception_) std::rethrow_exception(exception_);
  }
  // A refusal stays the likely cause of any later failure until the integration has passed
  // the time it happened at. That covers a function which refuses everything beyond some time:
  // then CVODE and IDA creep up to it in ever smaller accepted steps until the step size
  // falls below round-off.
  void ForgetRefusalsUpTo(double t) {
    if (refusal_time_ <= t) refusal_.clear();
  }
  bool HasRefusal() const { return !refusal_.empty(); }
  double refusal_time() const { return refusal_time_; }
  std::string RefusalMessage() const { return AtTime(refusal_time_) + ": " + refusal_; }
  long evaluations() const { return evaluations_; }

 private:
  std::string what_;
  std::string why_;  // reused by every call, so that a successful call does not allocate
  std::string refusal_;
  double refusal_time_ = 0.0;
  double lowest_time_ = -std::numeric_limits<double>::infinity();
  double highest_time_ = std::numeric_limits<double>::infinity();
  std::exception_ptr exception_;
  long evaluations_ = 0;
};

// y' = g(t, y) as SUNDIALS calls it. The user's function takes Eigen vectors, not maps of
// SUNDIALS' vectors, so the arguments are copied into these preallocated ones: a copy of a
// few numbers is cheaper than an allocation per call.
struct OdeCallbacks {
  OdeCallbacks(const OdeRightHandSide& right_hand_side, Eigen::Index size)
      : rhs(right_hand_side), y(size), y_dot(size), guard("the right-hand side") {}

  int Evaluate(double t, const Eigen::VectorXd& state, Eigen::VectorXd& derivative) noexcept {
    return guard.Run(t, [&](std::string& why) {
      return rhs(t, state, derivative, why) && guard.AcceptOutput(derivative, state.size(), why);
    });
  }

  // g(t, state) into `derivative`, reusing SUNDIALS' last evaluation when it was at this very
  // point: Dormand-Prince's last stage is evaluated at the new step's (t, y) (first same as
  // last), so the observer's y' costs nothing there.
  int EvaluateAtStep(double t, const Eigen::VectorXd& state, Eigen::VectorXd& derivative) noexcept {
    if (t == y_time && state == y) {
      derivative = y_dot;
      return kCallbackSucceeded;
    }
    return Evaluate(t, state, derivative);
  }

  const OdeRightHandSide& rhs;
  // CVODE's projection onto the ODE's invariant manifold, when it has one (IntegrateBdf).
  const OdeProjection* projection = nullptr;
  Eigen::VectorXd correction;
  Eigen::VectorXd error;
  // SUNDIALS' last call: its arguments and, when y_time is not NaN, the successful result.
  Eigen::VectorXd y;
  Eigen::VectorXd y_dot;
  double y_time = std::numeric_limits<double>::quiet_NaN();
  CallbackGuard guard;
};

int OdeRightHandSideCallback(sunrealtype t, N_Vector y, N_Vector y_dot, void* user_data) {
  auto& ode = *static_cast<OdeCallbacks*>(user_data);
  const double inside = ode.guard.InsideSegment(t);
  ode.y = AsEigen(y);
  const int flag = ode.Evaluate(inside, ode.y, ode.y_dot);
  ode.y_time = flag == kCallbackSucceeded ? inside : std::numeric_limits<double>::quiet_NaN();
  if (flag == kCallbackSucceeded) AsEigen(y_dot) = ode.y_dot;
  return flag;
}

// CVODE's projection after each step (CVProjFn): the correction that puts y on the manifold,
// and the error estimate projected the same way when CVODE passes one.
int OdeProjectionCallback(
    sunrealtype t, N_Vector y, N_Vector correction, sunrealtype, N_Vector error, void* user_data) {
  auto& ode = *static_cast<OdeCallbacks*>(user_data);
  ode.y = AsEigen(y);
  ode.y_time = std::numeric_limits<double>::quiet_NaN();  // y moves: the cached y' is stale
  if (error != nullptr) ode.error = AsEigen(error);
  const int flag = ode.guard.Run(t, [&](std::string& why) {
    return (*ode.projection)(t, ode.y, ode.correction, error != nullptr ? &ode.error : nullptr,
                             why) &&
           ode.guard.AcceptOutput(ode.correction, ode.y.size(), why) &&
           (error == nullptr || ode.guard.AcceptOutput(ode.error, ode.y.size(), why));
  });
  if (flag != kCallbackSucceeded) return flag;
  AsEigen(correction) = ode.correction;
  if (error != nullptr) AsEigen(error) = ode.error;
  return flag;
}

// F(t, x, x') = 0 as IDA calls it, with the same preallocated copies.
struct DaeCallbacks {
  DaeCallbacks(const DaeResidual& dae_residual, Eigen::Index size)
      : residual(dae_residual), x(size), x_dot(size), value(size), guard("the residual") {}

  const DaeResidual& residual;
  Eigen::VectorXd x;
  Eigen::VectorXd x_dot;
  Eigen::VectorXd value;
  CallbackGuard guard;
};

int DaeResidualCallback(
    sunrealtype t, N_Vector x, N_Vector x_dot, N_Vector residual, void* user_data) {
  auto& dae = *static_cast<DaeCallbacks*>(user_data);
  dae.x = AsEigen(x);
  dae.x_dot = AsEigen(x_dot);
  const double inside = dae.guard.InsideSegment(t);
  const int flag = dae.guard.Run(inside, [&](std::string& why) {
    return dae.residual(inside, dae.x, dae.x_dot, dae.value, why) &&
           dae.guard.AcceptOutput(dae.value, dae.x.size(), why);
  });
  if (flag == kCallbackSucceeded) AsEigen(residual) = dae.value;
  return flag;
}

// Owners of the integrators' memory (the *Free functions take the address of the pointer).
struct ErkStepMemoryDeleter {
  void operator()(void* memory) const { ERKStepFree(&memory); }
};
struct CvodeMemoryDeleter {
  void operator()(void* memory) const { CVodeFree(&memory); }
};
struct IdaMemoryDeleter {
  void operator()(void* memory) const { IDAFree(&memory); }
};
using ErkStepMemory = std::unique_ptr<void, ErkStepMemoryDeleter>;
using CvodeMemory = std::unique_ptr<void, CvodeMemoryDeleter>;
using IdaMemory = std::unique_ptr<void, IdaMemoryDeleter>;

// The work counters SUNDIALS keeps that the callbacks cannot count.
struct WorkCounters {
  long rejected_steps = 0;
  long newton_iterations = 0;
  long jacobian_evaluations = 0;
};

// One SUNDIALS integrator as the driver sees it: one internal step at a time, never past a
// stop time, restartable there.
class OneStepIntegrator {
 public:
  OneStepIntegrator(SundialsFlagNamer namer, const char* package)
      : namer_(namer), package_(package) {}
  virtual ~OneStepIntegrator() = default;
  OneStepIntegrator(const OneStepIntegrator&) = delete;
  OneStepIntegrator& operator=(const OneStepIntegrator&) = delete;

  // The next steps end exactly on `stop_time` and do not pass it.
  virtual void SetStopTime(double stop_time) = 0;
  // Upper bound of the step size (infinity: none).
  virtual void SetMaxStep(double max_step) = 0;
  // One internal step towards `stop_time`. Returns the package's flag; on success sets `t`,
  // solution() and (for a DAE) derivative().
  virtual int TakeStep(double stop_time, double& t) = 0;
  // Whether the step that returned `flag` ended on the stop time.
  virtual bool ReachedStopTime(int flag) const = 0;
  // Sets derivative() at (t, solution()) where the integrator does not provide it; false if
  // the callback refused (the reason is in guard()).
  virtual bool UpdateDerivative(double t) = 0;
  virtual const CallbackGuard& guard() const = 0;
  virtual CallbackGuard& guard() = 0;
  // The package's own interpolant of the last step at t (within that step) into `value`.
  virtual void Interpolate(double t, Eigen::VectorXd& value) = 0;

  // Starts afresh at (t, solution()) towards `stop_time`, forgetting the step history:
  // derivatives may jump at a breakpoint, and a multistep or FSAL history from before it
  // would be wrong. Returns the package's flag (negative if no restart was possible).
  int Restart(double t, double stop_time) {
    AddCounters(counted_);
    const int flag = ReInit(t);
    baseline_ = ReadCounters();  // ReInit resets some counters and not others (CVLS, IDALS)
    return flag < 0 ? flag : CompleteRestart(stop_time);
  }

  // Adds the work since the start to `summary`, across restarts.
  void AddTotals(SolveSummary& summary) const {
    WorkCounters totals = counted_;
    AddCounters(totals);
    summary.rejected_steps += totals.rejected_steps;
    summary.newton_iterations += totals.newton_iterations;
    summary.jacobian_evaluations += totals.jacobian_evaluations;
    summary.function_evaluations += guard().evaluations();
  }

  const Eigen::VectorXd& solution() const { return solution_; }
  const Eigen::VectorXd& derivative() const { return derivative_; }

  std::string FailureMessage(int flag, double t) const {
    const std::string flag_name = SundialsFlagName(namer_, flag);
    if (guard().HasRefusal()) return guard().RefusalMessage() + " (" + flag_name + ")";
    return package_ + " failed " + AtTime(t) + " with " + flag_name +
           (last_error_.empty() ? "" : ": " + last_error_);
  }

 protected:
  // The package's counters since it was created or last re-initialised.
  virtual WorkCounters ReadCounters() const = 0;
  // The package's re-initialisation at (t, solution(), derivative()).
  virtual int ReInit(double t) = 0;
  // What else a restart needs once the package is re-initialised.
  virtual int CompleteRestart(double) { return 0; }

  // For set-up calls, which fail only on a programming error.
  void Check(int flag, const char* call) const { CheckSundialsCall(namer_, flag, call); }

  SundialsContext context_;
  Eigen::VectorXd solution_;
  Eigen::VectorXd derivative_;
  std::string last_error_;

 private:
  void AddCounters(WorkCounters& counters) const {
    const WorkCounters now = ReadCounters();
    counters.rejected_steps += now.rejected_steps - baseline_.rejected_steps;
    counters.newton_iterations += now.newton_iterations - baseline_.newton_iterations;
    counters.jacobian_evaluations += now.jacobian_evaluations - baseline_.jacobian_evaluations;
  }

  SundialsFlagNamer namer_;
  std::string package_;
  WorkCounters counted_;   // up to the last restart
  WorkCounters baseline_;  // the package's counters right after the last restart
};

// What ARKODE's ERKStep and CVODE share as integrators of y' = g(t, y): the state vector, the
// step's result, the exact derivative there and the callbacks' guard. Each package's own calls
// stay in its class.
class OdeStepIntegrator : public OneStepIntegrator {
 public:
  // The exact y' = g(t, y) rather than the derivative of the package's interpolant, which
  // differs from it by the local error.
  bool UpdateDerivative(double t) override {
    return ode_.EvaluateAtStep(t, solution_, derivative_) == kCallbackSucceeded;
  }

  const CallbackGuard& guard() const override { return ode_.guard; }
  CallbackGuard& guard() override { return ode_.guard; }

 protected:
  OdeStepIntegrator(SundialsFlagNamer namer,
                    const char* package,
                    const OdeRightHandSide& rhs,
                    const Eigen::VectorXd& y_start)
      : OneStepIntegrator(namer, package),
        ode_(rhs, y_start.size()),
        state_(MakeSerialVector(y_start.size(), context_)) {
    solution_ = y_start;
    derivative_.resize(y_start.size());
    AsEigen(state_.get()) = y_start;
  }

  // One step by the package's one-step call `evolve(&reached)`, which returns its flag.
  template <typename Evolve>
  int StepWith(Evolve evolve, double& t) {
    double reached = t;
    const int flag = evolve(&reached);
    if (flag >= 0) {
      t = reached;
      solution_ = AsEigen(state_.get());
    }
    return flag;
  }

  // The package's interpolant of the last step at t by `get_dky(t, 0, vector)`.
  template <typename GetDky>
  void InterpolateWith(GetDky get_dky, const char* call, double t, Eigen::VectorXd& value) {
    if (!interpolated_) interpolated_ = MakeSerialVector(solution_.size(), context_);
    Check(get_dky(t, 0, interpolated_.get()), call);
    value = AsEigen(interpolated_.get());
  }

  OdeCallbacks ode_;
  NVectorPtr state_;
  NVectorPtr interpolated_;
};

// ARKODE's ERKStep with the Dormand-Prince 5(4) pair.
class DormandPrinceIntegrator final : public OdeStepIntegrator {
 public:
  static constexpr int kHermiteDegree = 4;

  DormandPrinceIntegrator(const OdeRightHandSide& rhs,
                          double t_start,
                          const Eigen::VectorXd& y_start,
                          const IntegratorOptions& options)
      : OdeStepIntegrator(ERKStepGetReturnFlagName, "ARKODE", rhs, y_start) {
    memory_.reset(ERKStepCreate(OdeRightHandSideCallback, t_start, state_.get(), context_));
    CheckSundialsPointer(memory_.get(), "ERKStepCreate");
    void* erk = memory_.get();
    Check(ERKStepSetErrHandlerFn(erk, KeepLastError, &last_error_), "ERKStepSetErrHandlerFn");
    Check(ERKStepSetUserData(erk, &ode_), "ERKStepSetUserData");
    Check(ERKStepSetTableNum(erk, ARKODE_DORMAND_PRINCE_7_4_5), "ERKStepSetTableNum");
    // Dense output: the Hermite interpolant of degree 4, whose error is of the method's local
    // order (h^5); degree 5 would cost a second extra right-hand side per step.
    Check(ERKStepSetInterpolantDegree(erk, kHermiteDegree), "ERKStepSetInterpolantDegree");
    Check(ERKStepSStolerances(erk, options.rtol, options.atol), "ERKStepSStolerances");
    Check(ERKStepSetInitStep(erk, options.initial_step), "ERKStepSetInitStep");
    if (std::isfinite(options.max_step)) {
      Check(ERKStepSetMaxStep(erk, options.max_step), "ERKStepSetMaxStep");
    }
  }

  void SetMaxStep(double max_step) override {
    Check(ERKStepSetMaxStep(memory_.get(), std::isfinite(max_step) ? max_step : 0.0),
          "ERKStepSetMaxStep");
  }
  void SetStopTime(double stop_time) override {
    Check(ERKStepSetStopTime(memory_.get(), stop_time), "ERKStepSetStopTime");
  }

  int TakeStep(double stop_time, double& t) override {
    return StepWith(
        [&](double* reached) {
          return ERKStepEvolve(memory_.get(), stop_time, state_.get(), reached, ARK_ONE_STEP);
        },
        t);
  }

  bool ReachedStopTime(int flag) const override { return flag == ARK_TSTOP_RETURN; }

  // ARKODE's Hermite interpolant of the step (degree up to 5).
  void Interpolate(double t, Eigen::VectorXd& value) override {
    InterpolateWith([&](double at, int order,
                        N_Vector into) { return ERKStepGetDky(memory_.get(), at, order, into); },
                    "ERKStepGetDky", t, value);
  }

 private:
  int ReInit(double t) override {
    return ERKStepReInit(memory_.get(), OdeRightHandSideCallback, t, state_.get());
  }

  WorkCounters ReadCounters() const override {
    WorkCounters counters;
    Check(ERKStepGetNumErrTestFails(memory_.get(), &counters.rejected_steps),
          "ERKStepGetNumErrTestFails");
    return counters;
  }

  ErkStepMemory memory_;
};

// CVODE's BDF with Newton iterations on a dense difference-quotient Jacobian.
class BdfIntegrator final : public OdeStepIntegrator {
 public:
  BdfIntegrator(const OdeRightHandSide& rhs,
                double t_start,
                const Eigen::VectorXd& y_start,
                const IntegratorOptions& options,
                const OdeProjection& projection)
      : OdeStepIntegrator(CVodeGetReturnFlagName, "CVODE", rhs, y_start) {
    const auto size = static_cast<sunindextype>(y_start.size());
    matrix_.reset(SUNDenseMatrix(size, size, context_));
    CheckSundialsPointer(matrix_.get(), "SUNDenseMatrix");
    linear_solver_.reset(SUNLinSol_Dense(state_.get(), matrix_.get(), context_));
    CheckSundialsPointer(linear_solver_.get(), "SUNLinSol_Dense");
    memory_.reset(CVodeCreate(CV_BDF, context_));
    CheckSundialsPointer(memory_.get(), "CVodeCreate");
    void* cvode = memory_.get();
    Check(CVodeSetErrHandlerFn(cvode, KeepLastError, &last_error_), "CVodeSetErrHandlerFn");
    Check(CVodeInit(cvode, OdeRightHandSideCallback, t_start, state_.get()), "CVodeInit");
    Check(CVodeSetUserData(cvode, &ode_), "CVodeSetUserData");
    Check(CVodeSStolerances(cvode, options.rtol, options.atol), "CVodeSStolerances");
    // Without a Jacobian function CVODE approximates it by difference quotients.
    Check(CVodeSetLinearSolver(cvode, linear_solver_.get(), matrix_.get()), "CVodeSetLinearSolver");
    Check(CVodeSetInitStep(cvode, options.initial_step), "CVodeSetInitStep");
    if (std::isfinite(options.max_step)) {
      Check(CVodeSetMaxStep(cvode, options.max_step), "CVodeSetMaxStep");
    }
    if (projection) {
      ode_.projection = &projection;
      ode_.correction.resize(y_start.size());
      ode_.error.resize(y_start.size());
      Check(CVodeSetProjFn(cvode, OdeProjectionCallback), "CVodeSetProjFn");
    }
  }

  void SetMaxStep(double max_step) override {
    Check(CVodeSetMaxStep(memory_.get(), std::isfinite(max_step) ? max_step : 0.0),
          "CVodeSetMaxStep");
  }
  void SetStopTime(double stop_time) override {
    Check(CVodeSetStopTime(memory_.get(), stop_time), "CVodeSetStopTime");
  }

  int TakeStep(double stop_time, double& t) override {
    return StepWith(
        [&](double* reached) {
          return CVode(memory_.get(), stop_time, state_.get(), reached, CV_ONE_STEP);
        },
        t);
  }

  bool ReachedStopTime(int flag) const override { return flag == CV_TSTOP_RETURN; }

  // CVODE's Nordsieck polynomial of the step (degree = the order used, at most 5).
  void Interpolate(double t, Eigen::VectorXd& value) override {
    InterpolateWith([&](double at, int order,
                        N_Vector into) { return CVodeGetDky(memory_.get(), at, order, into); },
                    "CVodeGetDky", t, value);
  }

 private:
  int ReInit(double t) override { return CVodeReInit(memory_.get(), t, state_.get()); }

  WorkCounters ReadCounters() const override {
    void* cvode = memory_.get();
    long error_test_failures = 0;
    long convergence_failures = 0;
    WorkCounters counters;
    Check(CVodeGetNumErrTestFails(cvode, &error_test_failures), "CVodeGetNumErrTestFails");
    Check(CVodeGetNumNonlinSolvConvFails(cvode, &convergence_failures),
          "CVodeGetNumNonlinSolvConvFails");
    Check(CVodeGetNumNonlinSolvIters(cvode, &counters.newton_iterations),
          "CVodeGetNumNonlinSolvIters");
    Check(CVodeGetNumJacEvals(cvode, &counters.jacobian_evaluations), "CVodeGetNumJacEvals");
    counters.rejected_steps = error_test_failures + convergence_failures;
    return counters;
  }

  SUNMatrixPtr matrix_;
  SUNLinearSolverPtr linear_solver_;
  CvodeMemory memory_;
};

// IDA's BDF for index-1 DAEs, with the algebraic components out of the error test.
class IdaIntegrator final : public OneStepIntegrator {
 public:
  IdaIntegrator(const DaeResidual& residual,
                double t_start,
                const Eigen::VectorXd& x_start,
                const Eigen::VectorXd& x_dot_start,
                const std::vector<bool>& differential,
                const IntegratorOptions& options)
      : OneStepIntegrator(IDAGetReturnFlagName, "IDA"),
        dae_(residual, x_start.size()),
        state_(MakeSerialVector(x_start.size(), context_)),
        state_derivative_(MakeSerialVector(x_start.size(), context_)),
        differential_ids_(MakeSerialVector(x_start.size(), context_)) {
    solution_ = x_start;
    derivative_ = x_dot_start;
    AsEigen(state_.get()) = x_start;
    AsEigen(state_derivative_.get()) = x_dot_start;
    auto ids = AsEigen(differential_ids_.get());
    for (Eigen::Index i = 0; i < ids.size(); ++i) {
      ids(i) = differential[static_cast<std::size_t>(i)] ? 1.0 : 0.0;  // IDA's convention
    }
    const auto size = static_cast<sunindextype>(x_start.size());
    matrix_.reset(SUNDenseMatrix(size, size, context_));
    CheckSundialsPointer(matrix_.get(), "SUNDenseMatrix");
    linear_solver_.reset(SUNLinSol_Dense(state_.get(), matrix_.get(), context_));
    CheckSundialsPointer(linear_solver_.get(), "SUNLinSol_Dense");
    memory_.reset(IDACreate(context_));
    CheckSundialsPointer(memory_.get(), "IDACreate");
    void* ida = memory_.get();
    Check(IDASetErrHandlerFn(ida, KeepLastError, &last_error_), "IDASetErrHandlerFn");
    Check(IDAInit(ida, DaeResidualCallback, t_start, state_.get(), state_derivative_.get()),
          "IDAInit");
    Check(IDASetUserData(ida, &dae_), "IDASetUserData");
    Check(IDASStolerances(ida, options.rtol, options.atol), "IDASStolerances");
    Check(IDASetLinearSolver(ida, linear_solver_.get(), matrix_.get()), "IDASetLinearSolver");
    Check(IDASetId(ida, differential_ids_.get()), "IDASetId");
    // Index 1: the algebraic components follow the differential ones through F = 0, so their
    // local error is not controlled. IDA then leaves them out of its Newton convergence test
    // too: they are only as converged as the differential components need (a nonlinear
    // algebraic variable measured 1.6e-7 relative at rtol 1e-10, against 2e-9 with it in the
    // tests at 1.7 times the steps; see the tests).
    Check(IDASetSuppressAlg(ida, SUNTRUE), "IDASetSuppressAlg");
    Check(IDASetInitStep(ida, options.initial_step), "IDASetInitStep");
    if (std::isfinite(options.max_step)) {
      Check(IDASetMaxStep(ida, options.max_step), "IDASetMaxStep");
    }
  }

  void SetMaxStep(double max_step) override {
    Check(IDASetMaxStep(memory_.get(), std::isfinite(max_step) ? max_step : 0.0), "IDASetMaxStep");
  }
  void SetStopTime(double stop_time) override {
    Check(IDASetStopTime(memory_.get(), stop_time), "IDASetStopTime");
  }

  int TakeStep(double stop_time, double& t) override {
    double reached = t;
    const int flag = IDASolve(memory_.get(), stop_time, &reached, state_.get(),
                              state_derivative_.get(), IDA_ONE_STEP);
    if (flag >= 0) {
      t = reached;
      solution_ = AsEigen(state_.get());
      derivative_ = AsEigen(state_derivative_.get());
    }
    return flag;
  }

  bool ReachedStopTime(int flag) const override { return flag == IDA_TSTOP_RETURN; }

  // IDA returns x' with x.
  bool UpdateDerivative(double) override { return true; }

  const CallbackGuard& guard() const override { return dae_.guard; }
  CallbackGuard& guard() override { return dae_.guard; }

  // IDA's interpolating polynomial of the step (degree = the order used, at most 5), which
  // covers the algebraic components too.
  void Interpolate(double t, Eigen::VectorXd& value) override {
    if (!interpolated_) interpolated_ = MakeSerialVector(solution_.size(), context_);
    Check(IDAGetDky(memory_.get(), t, 0, interpolated_.get()), "IDAGetDky");
    value = AsEigen(interpolated_.get());
  }

 private:
  int ReInit(double t) override {
    return IDAReInit(memory_.get(), t, state_.get(), state_derivative_.get());
  }

  // x' from before the breakpoint is only its left limit; where it jumps, IDA's error test
  // fails on every step size down to its minimum. IDACalcIC makes (x, x') consistent again on
  // the new side: the algebraic components and the derivatives of the differential ones from
  // F = 0 at fixed differential components (the callbacks already evaluate F on this side).
  int CompleteRestart(double stop_time) override {
    return IDACalcIC(memory_.get(), IDA_YA_YDP_INIT, stop_time);
  }

  WorkCounters ReadCounters() const override {
    void* ida = memory_.get();
    long error_test_failures = 0;
    long convergence_failures = 0;
    WorkCounters counters;
    Check(IDAGetNumErrTestFails(ida, &error_test_failures), "IDAGetNumErrTestFails");
    Check(IDAGetNumNonlinSolvConvFails(ida, &convergence_failures), "IDAGetNumNonlinSolvConvFails");
    Check(IDAGetNumNonlinSolvIters(ida, &counters.newton_iterations), "IDAGetNumNonlinSolvIters");
    Check(IDAGetNumJacEvals(ida, &counters.jacobian_evaluations), "IDAGetNumJacEvals");
    counters.rejected_steps = error_test_failures + convergence_failures;
    return counters;
  }

  DaeCallbacks dae_;
  NVectorPtr state_;
  NVectorPtr interpolated_;
  NVectorPtr state_derivative_;
  NVectorPtr differential_ids_;
  SUNMatrixPtr matrix_;
  SUNLinearSolverPtr linear_solver_;
  IdaMemory memory_;
};

// Where the integration stops and restarts: the breakpoints inside (t_start, t_end), sorted
// and merged where closer than round-off, then t_end.
std::vector<double> SegmentEnds(double t_start, double t_end, std::vector<double> breakpoints) {
  const double resolution = kBreakpointResolutionInRoundoffs *
                            std::numeric_limits<double>::epsilon() *
                            std::max(std::abs(t_start), std::abs(t_end));
  std::sort(breakpoints.begin(), breakpoints.end());
  std::vector<double> ends;
  double last_end = t_start;
  for (const double breakpoint : breakpoints) {
    if (breakpoint > last_end + resolution && breakpoint < t_end - resolution) {
      ends.push_back(breakpoint);
      last_end = breakpoint;
    }
  }
  ends.push_back(t_end);
  return ends;
}

// One run of an integrator from (t_start, its solution) to t_end, segment by segment between
// the breakpoints, calling the observer at the start and after every internal step.
class IntegrationRun {
 public:
  IntegrationRun(OneStepIntegrator& integrator,
                 double t_start,
                 const IntegratorOptions& options,
                 const IntegratorObserver& observer,
                 DenseOutput* dense_output)
      : integrator_(integrator),
        guard_(integrator.guard()),
        options_(options),
        observer_(observer),
        dense_output_(dense_output),
        t_(t_start),
        step_start_solution_(integrator.solution()) {}

  SolveSummary Run(double t_end, const std::vector<double>& breakpoints) {
    const double t_start = t_;
    if (auto stopped = Observe()) return *stopped;
    if (t_end == t_start) return Finish(SolveStatus::kConverged, "nothing to integrate");
    const std::vector<double> segment_ends = SegmentEnds(t_start, t_end, breakpoints);
    for (std::size_t segment = 0; segment < segment_ends.size(); ++segment) {
      const bool first = segment == 0;
      const bool last = segment + 1 == segment_ends.size();
      if (auto stopped = RunSegment(segment_ends[segment], first, last)) return *stopped;
    }
    return Finish(SolveStatus::kConverged, "reached t = " + FormatNumber(t_) + " s in " +
                                               std::to_string(summary_.steps) + " steps");
  }

 private:
  // Integrates from t_ to segment_end; returns the summary if the run stops early.
  std::optional<SolveSummary> RunSegment(double segment_end, bool first, bool last) {
    constexpr double kInfinity = std::numeric_limits<double>::infinity();
    guard_.SetSegment(first ? -kInfinity : std::nextafter(t_, kInfinity),
                      last ? kInfinity : std::nextafter(segment_end, -kInfinity));
    if (!first) {
      const int restart_flag = integrator_.Restart(t_, segment_end);
      guard_.RethrowIfThrown();
      if (restart_flag < 0) {
        return Finish(SolveStatus::kIntegratorFailure,
                      integrator_.FailureMessage(restart_flag, t_) + " (restart at a breakpoint)");
      }
    }
    integrator_.SetStopTime(segment_end);
    int flag = 0;
    do {
      if (summary_.steps >= options_.max_steps) {
        return Finish(SolveStatus::kTooManySteps, "stopped " + AtTime(t_) + " after " +
                                                      std::to_string(summary_.steps) +
                                                      " steps (IntegratorOptions::max_steps)");
      }
      const double step_start = t_;
      flag = integrator_.TakeStep(segment_end, t_);
      guard_.RethrowIfThrown();
      if (flag < 0 && RetryShorter(segment_end)) continue;
      if (flag < 0) {
        return Finish(SolveStatus::kIntegratorFailure, integrator_.FailureMessage(flag, t_));
      }
      if (!(t_ > step_start)) {
        // A stop-time return without a step, after a step that ended on the stop time itself.
        if (integrator_.ReachedStopTime(flag) && t_ == segment_end) break;
        return StepSizeTooSmall();
      }
      ++summary_.steps;
      if (dense_output_) RecordStep(step_start);
      guard_.ForgetRefusalsUpTo(t_);
      if (step_cap_ < kNoCap && !guard_.HasRefusal()) {
        step_cap_ = kNoCap;  // past the trouble: the error control decides again
        integrator_.SetMaxStep(options_.max_step);
      }
      if (auto stopped = Observe()) return stopped;
    } while (!integrator_.ReachedStopTime(flag));
    return std::nullopt;
  }

  // A trial step that reached ahead into a region where the right-hand side refuses (a
  // singularity further on) is fatal to ARKODE's explicit stepper, which cannot retry. Then
  // restart from the last accepted step with the step size capped at a quarter of the
  // distance to the refusal, shrinking it at each failure, so that the run stops close to the
  // singularity with the time at which it really failed. True if a retry was set up.
  bool RetryShorter(double segment_end) {
    if (!guard_.HasRefusal() || !(guard_.refusal_time() > t_)) return false;
    step_cap_ = std::min(step_cap_, guard_.refusal_time() - t_) / 4.0;
    if (!(step_cap_ > kMinRelativeCap * std::max(1.0, std::abs(t_)))) return false;
    guard_.ForgetRefusalsUpTo(guard_.refusal_time());
    if (integrator_.Restart(t_, segment_end) < 0) return false;
    integrator_.SetMaxStep(std::min(step_cap_, options_.max_step));
    integrator_.SetStopTime(segment_end);
    return true;
  }

  // The step just taken as a piece of the dense output: the interpolant at Lobatto nodes, with
  // the exact solution at both ends so that the pieces join continuously.
  void RecordStep(double step_start) {
    const std::vector<double> nodes = LobattoNodes(step_start, t_, kDenseOutputNodes);
    std::vector<Eigen::VectorXd> values(nodes.size());  // (two for a step of a few ulps)
    values.front() = step_start_solution_;
    values.back() = integrator_.solution();
    for (std::size_t j = 1; j + 1 < nodes.size(); ++j) integrator_.Interpolate(nodes[j], values[j]);
    dense_output_->AppendPiece(nodes, values);
    step_start_solution_ = integrator_.solution();
  }

  // Shows the observer the solution at t_; returns the summary if the run stops there.
  std::optional<SolveSummary> Observe() {
    const bool evaluated = integrator_.UpdateDerivative(t_);
    guard_.RethrowIfThrown();
    if (!evaluated) return Finish(SolveStatus::kIntegratorFailure, guard_.RefusalMessage());
    if (observer_ && !observer_(t_, integrator_.solution(), integrator_.derivative())) {
      return Finish(SolveStatus::kInterrupted,
                    "the observer stopped the integration " + AtTime(t_));
    }
    return std::nullopt;
  }

  // SUNDIALS only warns when t + h == t, and would go on "stepping" in place.
  SolveSummary StepSizeTooSmall() {
    const std::string what = "the step size fell below round-off of t";
    if (guard_.HasRefusal()) {
      return Finish(SolveStatus::kIntegratorFailure,
                    guard_.RefusalMessage() + " (" + what + " trying to get past it)");
    }
    return Finish(SolveStatus::kStepSizeTooSmall, what + " " + AtTime(t_));
  }

  SolveSummary Finish(SolveStatus status, std::string message) {
    integrator_.AddTotals(summary_);
    summary_.status = status;
    summary_.message = std::move(message);
    summary_.stop_time = t_;
    return summary_;
  }

  static constexpr double kNoCap = std::numeric_limits<double>::infinity();
  // Nodes per step of the dense output: 6 reproduce a polynomial of degree 5, the highest any
  // of the three packages interpolates with (BDF order 5, ARKODE's Hermite degree 5).
  static constexpr int kDenseOutputNodes = 6;
  // Retries of RetryShorter() end when the cap falls below this, relative to |t|: the
  // singularity is then located to round-off.
  static constexpr double kMinRelativeCap = 1e-12;
  double step_cap_ = kNoCap;
  OneStepIntegrator& integrator_;
  CallbackGuard& guard_;
  const IntegratorOptions& options_;
  const IntegratorObserver& observer_;
  DenseOutput* dense_output_;
  SolveSummary summary_;
  double t_;
  Eigen::VectorXd step_start_solution_;
};

void CheckInterval(double t_start, double t_end, const std::vector<double>& breakpoints) {
  if (!std::isfinite(t_start) || !std::isfinite(t_end) || t_end < t_start) {
    throw UsageError("the interval [" + FormatNumber(t_start) + ", " + FormatNumber(t_end) +
                     "]: must be finite with t_end >= t_start");
  }
  for (const double breakpoint : breakpoints) {
    if (!std::isfinite(breakpoint)) {
      throw UsageError("breakpoint " + FormatNumber(breakpoint) + ": must be finite");
    }
  }
}

void CheckStart(const char* name, const Eigen::VectorXd& start, Eigen::Index size) {
  if (start.size() != size) {
    throw UsageError(std::string(name) + " has " + std::to_string(start.size()) +
                     " values: must have " + std::to_string(size));
  }
  if (!start.allFinite()) throw UsageError(std::string(name) + ": must be finite");
}

void CheckOdeArguments(const OdeRightHandSide& rhs,
                       double t_start,
                       const Eigen::VectorXd& y_start,
                       double t_end,
                       const std::vector<double>& breakpoints) {
  if (!rhs) throw UsageError("the right-hand side is empty");
  if (y_start.size() == 0) throw UsageError("y_start is empty: must have at least one value");
  CheckStart("y_start", y_start, y_start.size());
  CheckInterval(t_start, t_end, breakpoints);
}

void CheckDenseOutput(const DenseOutput* dense_output, Eigen::Index size) {
  if (dense_output && (!dense_output->empty() || dense_output->size() != size)) {
    throw UsageError("the dense output must be empty and of the state's size " +
                     std::to_string(size));
  }
}

}  // namespace

void IntegratorOptions::Validate() const {
  constexpr const char* kOwner = "IntegratorOptions";
  RequireOption(rtol > 0.0 && std::isfinite(rtol), kOwner, "rtol", rtol, "must be > 0 and finite");
  RequireOption(atol >= 0.0 && std::isfinite(atol), kOwner, "atol", atol,
                "must be >= 0 and finite");
  RequireOption(initial_step >= 0.0 && std::isfinite(initial_step), kOwner, "initial_step",
                initial_step, "must be >= 0 and finite (0: SUNDIALS chooses)");
  RequireOption(max_step > 0.0, kOwner, "max_step", max_step, "must be > 0 (infinity: no bound)");
  RequireOption(max_steps >= 1, kOwner, "max_steps", max_steps, "must be >= 1");
}

SolveSummary IntegrateDormandPrince(const OdeRightHandSide& rhs,
                                    double t_start,
                                    const Eigen::VectorXd& y_start,
                                    double t_end,
                                    const std::vector<double>& breakpoints,
                                    const IntegratorOptions& options,
                                    const IntegratorObserver& observer,
                                    DenseOutput* dense_output) {
  options.Validate();
  CheckOdeArguments(rhs, t_start, y_start, t_end, breakpoints);
  CheckDenseOutput(dense_output, y_start.size());
  DormandPrinceIntegrator integrator(rhs, t_start, y_start, options);
  return IntegrationRun(integrator, t_start, options, observer, dense_output)
      .Run(t_end, breakpoints);
}

SolveSummary IntegrateBdf(const OdeRightHandSide& rhs,
                          double t_start,
                          const Eigen::VectorXd& y_start,
                          double t_end,
                          const std::vector<double>& breakpoints,
                          const IntegratorOptions& options,
                          const IntegratorObserver& observer,
                          DenseOutput* dense_output) {
  return IntegrateProjectedBdf(rhs, OdeProjection(), t_start, y_start, t_end, breakpoints, options,
                               observer, dense_output);
}

SolveSummary IntegrateProjectedBdf(const OdeRightHandSide& rhs,
                                   const OdeProjection& projection,
                                   double t_start,
                                   const Eigen::VectorXd& y_start,
                                   double t_end,
                                   const std::vector<double>& breakpoints,
                                   const IntegratorOptions& options,
                                   const IntegratorObserver& observer,
                                   DenseOutput* dense_output) {
  options.Validate();
  CheckOdeArguments(rhs, t_start, y_start, t_end, breakpoints);
  CheckDenseOutput(dense_output, y_start.size());
  BdfIntegrator integrator(rhs, t_start, y_start, options, projection);
  return IntegrationRun(integrator, t_start, options, observer, dense_output)
      .Run(t_end, breakpoints);
}

SolveSummary IntegrateIda(const DaeResidual& residual,
                          double t_start,
                          const Eigen::VectorXd& x_start,
                          const Eigen::VectorXd& x_dot_start,
                          const std::vector<bool>& differential,
                          double t_end,
                          const std::vector<double>& breakpoints,
                          const IntegratorOptions& options,
                          const IntegratorObserver& observer,
                          DenseOutput* dense_output) {
  options.Validate();
  if (!residual) throw UsageError("the residual is empty");
  if (x_start.size() == 0) throw UsageError("x_start is empty: must have at least one value");
  CheckStart("x_start", x_start, x_start.size());
  CheckStart("x_dot_start", x_dot_start, x_start.size());
  if (differential.size() != static_cast<std::size_t>(x_start.size())) {
    throw UsageError("differential has " + std::to_string(differential.size()) +
                     " flags: must have one per component of x_start (" +
                     std::to_string(x_start.size()) + ")");
  }
  CheckInterval(t_start, t_end, breakpoints);
  CheckDenseOutput(dense_output, x_start.size());
  IdaIntegrator integrator(residual, t_start, x_start, x_dot_start, differential, options);
  return IntegrationRun(integrator, t_start, options, observer, dense_output)
      .Run(t_end, breakpoints);
}

}  // namespace servokit
