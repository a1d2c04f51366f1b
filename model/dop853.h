#pragma once
// Private to rocklab::model: explicit embedded Runge-Kutta pairs written for
// the rocking models' small states (n <= 16) in fixed arrays, no allocation
// and no library calls on the stepping path: on a 2-state system SUNDIALS'
// per-step bookkeeping, not the arithmetic, was the cost
// (docs/performance.md, "Issue 33"). One stepper (EmbeddedRungeKutta: the
// step-size control, the stop time, root finding on the dense output, the
// restart) serves two pairs:
// - Dop853: Dormand and Prince's 8(5,3) (Hairer, Norsett & Wanner, Solving
//   ODEs I, 2nd ed., sec. II.10, "DOP853"): order 8, its error estimated
//   from the embedded orders 5 and 3 together, with the method's own dense
//   output of order 7. Simulate's Housner model.
// - Dopri5: Dormand and Prince's 5(4) (ibid., II.5, "DOPRI5"): order 5,
//   seven stages with the last the next step's first, and Shampine's dense
//   output of order 4 from the same stages. The model node, which stops at
//   every 1 ms sample (one step of six right-hand sides per sample).

#include <array>

namespace rocklab::model::detail {

class OdeSystem;

class EmbeddedRungeKutta {
 public:
  static constexpr int kMaxN = 16;
  static constexpr int kMaxRoots = 16;

  virtual ~EmbeddedRungeKutta() = default;
  EmbeddedRungeKutta(const EmbeddedRungeKutta&) = delete;
  EmbeddedRungeKutta& operator=(const EmbeddedRungeKutta&) = delete;

  /// Restarts at t0_s from y0; clears the step history and the counters.
  /// The first step is the last one proposed (keep_step; after an impact
  /// the motion keeps its time scale) or Hairer's starting-step estimate.
  void ReInit(double t0_s, const double* y0, bool keep_step = true);
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
  /// @throws StepFailure (model/cvode.h) when the step falls below
  ///         SmallestStep(t); the last step's end (t_step_end, y_step_end)
  ///         is then where a restart can go on from
  /// @throws IntegratorError when the right-hand side fails
  Result Advance(double tout_s, double tstop_s);

  void RootsFound(int* found) const;
  double t_s() const { return t_; }
  const double* y() const { return y_out_.data(); }
  double* y_mut() { return y_out_.data(); }
  /// The smallest step tried from t_s: 2 eps max(|t_s|, 1), 2-4 ulp (ARKODE
  /// goes on to 1 ulp; 16 ulp stopped the complex model's crossings at
  /// micro-rocking late in a long record, docs/models.md).
  static double SmallestStep(double t_s);
  /// The end of the last step taken: all that is integrated.
  double t_step_end() const { return t_new_; }
  const double* y_step_end() const { return y_new_.data(); }

  /// Work since the last ReInit.
  long steps() const { return steps_; }
  long rhs_evals() const { return rhs_evals_; }
  long error_test_fails() const { return fails_; }

 protected:
  using Vec = std::array<double, kMaxN>;
  static constexpr int kMaxStages = 16;

  /// The pair's constants for the shared step-size control.
  struct Pair {
    int order;           ///< of the solution: the step ratio is err^(-1/order)
    double max_factor;   ///< largest step ratio after an acceptance
    int end_stage;       ///< k_[end_stage] is f at the step's end, the next step's k_[0]
    bool end_in_try;     ///< TryStep computes it (needed for its error estimate)
  };
  EmbeddedRungeKutta(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots,
                     Pair pair);

  /// One attempt of a step of size h from (t_old_, y_old_), k_[0] its
  /// f, ending at t_end_s (t_old_ + h, or the stop time exactly): the
  /// stages into k_, the solution into y, and the error's weighted RMS
  /// norm (<= 1: accepted).
  virtual double TryStep(double h, double t_end_s, Vec& y) = 0;
  /// The dense output's coefficients of the current step [t_old_, t_new_].
  virtual void PrepareDense() = 0;
  /// The dense output at x = (t - t_old_) / (t_new_ - t_old_) in [0, 1).
  virtual void Dense(double x, double* y) const = 0;

  void Rhs(double t_s, const double* y, double* ydot);
  double Weight(int i, double y_old, double y_new) const;

  int n_;
  double rtol_;
  Vec atol_{};
  // The current step [t_old_, t_new_]; at a (re)start both are t0.
  double t_old_{}, t_new_{};
  Vec y_old_{}, y_new_{};
  std::array<Vec, kMaxStages> k_{};  // the stages; k_[0] = f(t_old, y_old)

 private:
  void Roots(double t_s, const double* y, double* g);
  double InitialStep();
  void Step(double tstop_s);
  void Interpolate(double t_s, double* y);
  // g at t_s inside the current step (y_new_ at its end).
  void RootsAt(double t_s, double* y, double* g);
  // The earliest crossing in (t_lo_, t_hi_s] with g_hi its roots at t_hi_s.
  bool FindRoot(double t_hi_s, const double* g_hi);

  int roots_;
  OdeSystem& system_;
  Pair pair_;
  double max_step_s_;
  std::array<int, kMaxRoots> direction_{};

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

/// Dormand-Prince 8(5,3) with its order-7 dense output.
class Dop853 : public EmbeddedRungeKutta {
 public:
  /// @param n equations, 1 .. kMaxN; @param atol n absolute tolerances;
  /// @param max_step_s largest step (0: none); @param roots 1 .. kMaxRoots
  Dop853(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots);

 private:
  double TryStep(double h, double t_end_s, Vec& y) override;
  void PrepareDense() override;
  void Dense(double x, double* y) const override;
  std::array<Vec, 7> dense_{};  // the dense output's coefficients of the current step
};

/// Dormand-Prince 5(4) with Shampine's order-4 dense output.
class Dopri5 : public EmbeddedRungeKutta {
 public:
  /// As Dop853's.
  Dopri5(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, int roots);

 private:
  double TryStep(double h, double t_end_s, Vec& y) override;
  void PrepareDense() override;
  void Dense(double x, double* y) const override;
  std::array<Vec, 4> dense_{};
};

}  // namespace rocklab::model::detail
