#pragma once
// Private to rocklab::model: RAII wrapper of a SUNDIALS 6.4 CVODE integrator
// (SUNContext, serial N_Vector, fixed-point nonlinear solver, CVODE memory).
// Every SUNDIALS call is checked and a failure throws std::runtime_error
// naming the function.

#include <array>
#include <memory>
#include <stdexcept>

struct _generic_N_Vector;

namespace rocklab::model::detail {

/// A failed integrator step (CVode, ERKStepEvolve): the message names the
/// flag, the time reached, the time asked for and the state.
class IntegratorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A step the fixed-array steppers (model/dop853.h) gave up (too small, or
/// its error test failed too often): Cvode::Advance restarts them from their
/// last step's end, as it restarts CVODE and ARKODE.
class StepFailure : public IntegratorError {
 public:
  using IntegratorError::IntegratorError;
};

/// A small ODE y' = f(t, y) with root functions g(t, y) (three, or the
/// number given to Cvode).
class OdeSystem {
 public:
  virtual ~OdeSystem() = default;
  /// Right-hand side; returns 0 on success, > 0 for a recoverable failure.
  virtual int Rhs(double t_s, const double* y, double* ydot) = 0;
  /// The root functions.
  virtual int Roots(double t_s, const double* y, double* g) = 0;
};

/// Adams-Moulton with a fixed-point (functional) corrector: the rocking
/// equations are non-stiff (Jacobian eigenvalues ~ p, and the fast motion of
/// the complex formulation near chi -> 0 is the solution itself, so accuracy,
/// not stability, bounds the step). No Jacobian, no matrix, high order.
class Cvode {
 public:
  static constexpr int kRoots = 3;         ///< the rocking models' roots
  static constexpr int kMaxRoots = 16;     ///< a stack's: two per interface
  static constexpr int kMaxEquations = 16;  ///< a stack's: angle and rate per interface

  /// CVODE's Adams-Moulton (multistep: its history carries over from step
  /// to step) or ARKODE's explicit Runge-Kutta (ERKStep, one step at a
  /// time: nothing to lose at a kink of the forcing where it stops).
  /// Or Dormand and Prince's 8(5,3) or 5(4) with their dense outputs, in
  /// fixed arrays (model/dop853.h; no SUNDIALS call on their stepping path).
  enum class Method { kAdams, kRungeKutta, kDormandPrince853, kDormandPrince5 };
  /// Order of the Runge-Kutta method.
  static constexpr int kRungeKuttaOrder = 5;
  /// Degree of its dense output (ERKStepSetInterpolantDegree).
  static constexpr int kRungeKuttaInterpolantDegree = 3;
  /// @param n number of equations, 1 .. kMaxEquations (fixed-length vector
  ///        operations up to 4, SUNDIALS' serial ones beyond)
  /// @param atol absolute tolerances, one per equation
  /// @param roots number of root functions, 1 .. kMaxRoots
  Cvode(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s,
        Method method = Method::kAdams, int roots = kRoots);
  ~Cvode();
  Cvode(const Cvode&) = delete;
  Cvode& operator=(const Cvode&) = delete;

  /// Restart at t0_s from y0 (n values); clears the integration history.
  void ReInit(double t0_s, const double* y0);
  /// Root directions (+1 rising, -1 falling, 0 both) for the three roots.
  void SetRootDirection(std::array<int, kRoots> direction);
  /// The same for as many roots as given at construction.
  void SetRootDirection(const int* direction);
  /// Relative and absolute (n values) tolerances from the next step on.
  void SetTolerances(double rtol, const double* atol);
  /// Largest internal step, s; 0 for none.
  void SetMaxStep(double max_step_s);

  enum class Result { kReached, kRoot };
  /// Integrates towards tout_s, never evaluating the right-hand side beyond
  /// tstop_s >= tout_s (CVodeSetStopTime; +infinity: no bound). The internal
  /// steps may pass tout_s (up to tstop_s): the solution at tout_s is then
  /// CVODE's interpolant (CVodeGetDky), and the integration history is kept
  /// across outputs. Stops at the first root. The solution is in y().
  /// When CVODE gives up (repeated error-test or convergence failures, as at
  /// a jump of the forcing nobody declared) it restarts from the last step
  /// it completed (with a fresh history) and goes on; when that fails again
  /// at the same time it restarts 16 ulp later (a jump right there); it
  /// throws when that fails too.
  Result Advance(double tout_s, double tstop_s);
  /// Advance(tout_s, tout_s): never evaluates the right-hand side beyond tout_s.
  Result Advance(double tout_s) { return Advance(tout_s, tout_s); }

  /// Solver work since construction, summed over every ReInit.
  struct Stats {
    long steps{};             ///< internal steps taken
    long rhs_evals{};         ///< right-hand side evaluations
    long error_test_fails{};  ///< local error test failures
    long recoveries{};        ///< restarts after CVODE gave up (see Advance)
  };
  Stats stats() const;
  /// Which roots were found by the last Advance returning kRoot (+1/-1 the
  /// direction, 0 not found).
  std::array<int, kRoots> RootsFound();
  /// The same for as many roots as given at construction (into `found`).
  void RootsFound(int* found);

  double t_s() const { return t_; }
  const double* y() const;
  double* y_mut();

 private:
  struct Handles;
  static int RhsThunk(double t, _generic_N_Vector* y, _generic_N_Vector* ydot, void* user);
  static int RootThunk(double t, _generic_N_Vector* y, double* g, void* user);
  Stats Counters() const;  // the integrator's counters since its last (re)initialisation
  // Where Advance goes on after the integrator gave up at t_done_s (see
  // Advance; nudge_s > 0: that far instead of 16 ulp): false when it gave
  // up there twice already.
  bool RecoveryTime(double t_done_s, double tstop_s, double nudge_s, double* t_restart_s);
  void AddCounters();      // moves them (reset by ReInit) into done_
  std::unique_ptr<Handles> h_;
  int n_{};
  int roots_{kRoots};
  double t_{};
  Stats done_;  // work before the last ReInit
  double last_failure_t_{-1e300};  // where Advance last restarted after a failure, s
  bool nudged_{false};             // that restart was moved past the failure time
};

}  // namespace rocklab::model::detail
