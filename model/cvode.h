#pragma once
// Private to rocklab::model: RAII wrapper of a SUNDIALS 6.4 CVODE integrator
// (SUNContext, serial N_Vector, fixed-point nonlinear solver, CVODE memory).
// Every SUNDIALS call is checked and a failure throws std::runtime_error
// naming the function.

#include <array>
#include <memory>

struct _generic_N_Vector;

namespace rocklab::model::detail {

/// A small ODE y' = f(t, y) with three root functions g(t, y).
class OdeSystem {
 public:
  virtual ~OdeSystem() = default;
  /// Right-hand side; returns 0 on success, > 0 for a recoverable failure.
  virtual int Rhs(double t_s, const double* y, double* ydot) = 0;
  /// The three root functions.
  virtual int Roots(double t_s, const double* y, double* g) = 0;
};

/// Adams-Moulton with a fixed-point (functional) corrector: the rocking
/// equations are non-stiff (Jacobian eigenvalues ~ p, and the fast motion of
/// the complex formulation near chi -> 0 is the solution itself, so accuracy,
/// not stability, bounds the step). No Jacobian, no matrix, high order.
class Cvode {
 public:
  static constexpr int kRoots = 3;

  /// @param n number of equations (<= 3 here)
  /// @param atol absolute tolerances, one per equation
  Cvode(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s);
  ~Cvode();
  Cvode(const Cvode&) = delete;
  Cvode& operator=(const Cvode&) = delete;

  /// Restart at t0_s from y0 (n values); clears the integration history.
  void ReInit(double t0_s, const double* y0);
  /// Root directions (+1 rising, -1 falling, 0 both) for the three roots.
  void SetRootDirection(std::array<int, kRoots> direction);

  enum class Result { kReached, kRoot };
  /// Integrates towards tout_s, never evaluating the right-hand side beyond
  /// it (CVodeSetStopTime). Stops at the first root. The solution is in y().
  Result Advance(double tout_s);
  /// Which roots were found by the last Advance returning kRoot (+1/-1 the
  /// direction, 0 not found).
  std::array<int, kRoots> RootsFound();

  double t_s() const { return t_; }
  const double* y() const;
  double* y_mut();

 private:
  struct Handles;
  static int RhsThunk(double t, _generic_N_Vector* y, _generic_N_Vector* ydot, void* user);
  static int RootThunk(double t, _generic_N_Vector* y, double* g, void* user);
  std::unique_ptr<Handles> h_;
  int n_{};
  double t_{};
};

}  // namespace rocklab::model::detail
