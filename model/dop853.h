#pragma once
// Private to rocklab::model: Dormand and Prince's explicit Runge-Kutta
// 8(5,3) (Hairer, Norsett & Wanner, Solving ODEs I, 2nd ed., sec. II.10,
// "DOP853"): order 8, its error estimated from the embedded orders 5 and 3
// together, with the method's own dense output of order 7 and root finding
// on it. Written for the rocking models' small states (n <= 16) in fixed
// arrays, no allocation and no library calls on the stepping path: on a
// 2-state system SUNDIALS' per-step bookkeeping, not the arithmetic, was
// the cost (docs/performance.md, "Issue 33").

#include <array>

namespace rocklab::model::detail {

class OdeSystem;

class Dop853 {
 public:
  static constexpr int kMaxN = 16;
  static constexpr int kMaxRoots = 16;

  /// @param n equations, 1 .. kMaxN; @param atol n absolute tolerances;
  /// @param max_step_s largest step (0: none); @param roots 1 .. kMaxRoots
  Dop853(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots);

  /// Restarts at t0_s from y0; clears the step history and the counters.
  void ReInit(double t0_s, const double* y0);
  void SetRootDirection(const int* direction);
  void SetTolerances(double rtol, const double* atol);
  void SetMaxStep(double max_step_s);

  enum class Result { kReached, kRoot };
  /// Steps towards tout_s (never beyond tstop_s >= tout_s); the solution at
  /// tout_s, or at the first root before it, is interpolated from the step
  /// holding it, and the steps carry on from there at the next call. A root
  /// is reported at the first time the tolerance 100 ulp (of max(|t|, |h|))
  /// places on the far side of the crossing, as CVODE does. A root function
  /// exactly zero where an interval starts is not reported in it.
  /// @throws IntegratorError when the step falls below 16 ulp of t or the
  ///         right-hand side fails for good
  Result Advance(double tout_s, double tstop_s);

  void RootsFound(int* found) const;
  double t_s() const { return t_; }
  const double* y() const { return y_out_.data(); }
  double* y_mut() { return y_out_.data(); }

  /// Work since the last ReInit.
  long steps() const { return steps_; }
  long rhs_evals() const { return rhs_evals_; }
  long error_test_fails() const { return fails_; }

 private:
  using Vec = std::array<double, kMaxN>;
  static constexpr int kStages = 16;  // 12 of the step, f at its end, 3 for the dense output

  void Rhs(double t_s, const double* y, double* ydot);
  void Roots(double t_s, const double* y, double* g);
  double InitialStep();
  void Step(double tstop_s);
  void PrepareDense();
  void Interpolate(double t_s, double* y);
  // g at t_s inside the current step (y_new_ at its end).
  void RootsAt(double t_s, double* y, double* g);
  // The earliest crossing in (t_lo_, t_hi_s] with g_hi its roots at t_hi_s.
  bool FindRoot(double t_hi_s, const double* g_hi);

  int n_;
  int roots_;
  OdeSystem& system_;
  double rtol_;
  Vec atol_{};
  double max_step_s_;
  std::array<int, kMaxRoots> direction_{};

  // The current step [t_old_, t_new_]; at a (re)start both are t0.
  double t_old_{}, t_new_{};
  Vec y_old_{}, y_new_{};
  std::array<Vec, kStages> k_{};  // k_[0] = f(t_old, y_old), k_[12] = f(t_new, y_new)
  std::array<Vec, 7> dense_{};    // the dense output's coefficients of the current step
  bool dense_ready_{false};
  bool started_{false};           // a step was taken since ReInit (h_ set)
  bool last_rejected_{false};
  double h_{};                    // the next step's size
  double h_hint_{};               // the first step's after a restart (0: estimate it)

  // Root search: the part of the current step before t_lo_ is searched.
  double t_lo_{};
  std::array<double, kMaxRoots> g_lo_{};
  std::array<double, kMaxRoots> g_new_{};  // at t_new_
  std::array<int, kMaxRoots> found_{};

  double t_{};     // the time of the last result
  Vec y_out_{};    // the solution there
  long steps_{}, rhs_evals_{}, fails_{};
};

}  // namespace rocklab::model::detail
