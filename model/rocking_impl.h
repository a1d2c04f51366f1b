#pragma once
// Private to rocklab::model: the CVODE-driven regime machine shared by the
// Housner and complex models (rest -> uplift -> rocking -> impacts -> rest or
// overturn, docs/errata.md item 6). Derived classes supply the equations.

#include <algorithm>
#include <limits>
#include <memory>

#include "model/cvode.h"
#include "model/rocking_model.h"

namespace rocklab::model::detail {

class CvodeRockingModel : public RockingModel, protected OdeSystem {
 public:
  void Reset(double t0_s, double theta0, double theta_dot0) final;
  void AdvanceTo(double t_s, const Forcing& forcing) final { AdvanceAhead(t_s, forcing, t_s); }
  void AdvanceAhead(double t_s, const Forcing& forcing, double horizon_s) final;
  const ModelState& state() const final { return state_; }
  const BlockParams& params() const final { return params_; }
  const ModelOptions& options() const final { return options_; }
  SolverStats solver_stats() const final;

 protected:
  CvodeRockingModel(const BlockParams& params, const ModelOptions& options);
  /// Creates the integrator; call from the derived constructor.
  void Init(int n, const double* atol);
  /// Changes the absolute tolerances (n values, as Init's); they take effect
  /// at the next restart of the integrator, which the caller must make.
  void SetAbsTolerances(const double* atol);

  // --- supplied by the formulation -----------------------------------------
  /// Equations while rocking; u_g'' from table_accel(t).
  virtual void RockingRhs(double t_s, const double* y, double* ydot) = 0;
  /// g[0]: impact, g[1]: overturn (rising through zero), g[2]: a switch of
  /// the formulation's own (rising through zero; a constant when it has none).
  virtual void RockingRoots(const double* y, double* g) const = 0;
  /// Direction of the impact root for the current state (the overturn root rises).
  virtual int ImpactRootDirection() const = 0;
  /// Initial state from theta0, theta_dot0 (not both zero); `side` is +1 or -1.
  virtual void InitialState(double theta0, double theta_dot0, int side, double* y) = 0;
  /// Applies an impact found at the current time to y (in place); returns
  /// whether the integrator must be re-initialised.
  virtual bool ApplyImpact(double* y) = 0;
  /// True when the model should go back to rest at this impact for a reason
  /// of its own (besides the impact-interval rule).
  virtual bool RestAtImpact(const double* /*y*/) const { return false; }
  /// Direction of the switch root g[2] for the current state (+1 rising,
  /// -1 falling, 0 both).
  virtual int SwitchRootDirection() const { return +1; }
  /// A crossing of the origin solved in closed form between two times
  /// (the complex model's matched inner solution): the integrator stops at
  /// t_entry and restarts at t_exit; the impact is at t_impact.
  struct Passage {
    double t_entry_s{};
    double t_impact_s{};
    double t_exit_s{};
    double impact_theta_dot{};  ///< rad/s, just before the impact
    double after_theta_dot{};   ///< rad/s, just after it
  };
  enum class SwitchResult { kNone, kReinit, kPassage };
  /// Called when g[2] crosses zero (no impact at the same time) at t_s; may
  /// change y in place (kReinit: restart the integrator there) or solve a
  /// passage from there (kPassage: `passage` filled, y untouched).
  virtual SwitchResult ApplySwitch(double /*t_s*/, double* /*y*/, Passage* /*passage*/) {
    return SwitchResult::kNone;
  }
  /// Inside the pending passage: state_ (not energy) at t_s.
  virtual void FillPassageState(double /*t_s*/) {}
  /// The state at the end of the pending passage into y (the formulation's
  /// own coordinates switch there).
  virtual void FinishPassage(double* /*y*/) {}
  /// theta, theta_dot, chi, psi and equations of y into state_ (energy is
  /// filled by the base).
  virtual void FillState(const double* y) = 0;
  /// The equations an uplift from rest starts with.
  virtual Equations RestEquations() const = 0;

  /// u_g'' at t_s, evaluated inside the current segment between two stops of
  /// the integrator: at a stop that is a jump of the forcing, the side of
  /// the segment being integrated (t is moved by one ulp at most).
  double table_accel(double t_s) const {
    return forcing_->TableAcceleration(std::min(std::max(t_s, segment_lo_s_), segment_hi_s_));
  }

  BlockParams params_;
  ModelOptions options_;
  ModelState state_;

 private:
  int Rhs(double t_s, const double* y, double* ydot) final;
  int Roots(double t_s, const double* y, double* g) final;
  void EnterRest(double t_s);
  void StartRocking(double t_s, double theta0, double theta_dot0, int side);
  void Emit(double t_s, EventKind kind, double value);
  void UpdateState(double t_s, const double* y);
  // Time and energy of state_ from its theta and theta_dot.
  void UpdateState(double t_s);
  // Sets the segment [t_from, t_to] table_accel evaluates in.
  void SetSegment(double t_from_s, double t_to_s);
  // Advances the integrator to tout_s (stopping before tstop_s) with the
  // step bound of the regime.
  Cvode::Result Integrate(double tout_s, double tstop_s);
  // Restarts the integrator at a jump of the forcing at t_s.
  void RestartAtDiscontinuity(double t_s);
  // Restarts the integrator at t_s from y_ in the rocking regime.
  void RestartRocking(double t_s);
  // While the table could lift the block (|u_g''| above g tan(alpha) of
  // either pivot) it does not come to rest (docs/errata.md item 6).
  bool TableAllowsRest(double t_s) const;
  // An impact at t_s (event, rest rules); returns true when the block rests.
  bool Impact(double t_s, double theta_dot);
  // Steps through the pending passage up to t_s; returns false when t_s
  // lies inside it (state_ is then the passage's at t_s).
  bool AdvancePassage(double t_s);

  int n_{};
  std::unique_ptr<Cvode> cvode_;
  const Forcing* forcing_{nullptr};  // non-owning; valid during AdvanceTo only
  double uplift_minus_mps2_{};       // g tan(alpha_-): u_g'' above it lifts onto the -x pivot
  double uplift_plus_mps2_{};        // g tan(alpha_+): u_g'' below minus it lifts onto the +x pivot
  double last_impact_s_{-std::numeric_limits<double>::infinity()};
  bool rest_checked_{false};         // uplift criterion checked at the current rest time
  double segment_lo_s_{};            // table_accel clamps its time to [lo, hi]
  double segment_hi_s_{};
  long restarts_{};                  // restarts at declared discontinuities since Reset
  double rocking_time_s_{};          // since Reset, s
  double eq10_time_s_{};             // since Reset, s
  Cvode::Stats stats_at_reset_;
  double max_step_set_s_{-1};        // the integrator's step bound as last set, s (0: none)
  double y_[Cvode::kMaxEquations]{};  // scratch state, no allocation on the stepping path
  Passage passage_;                   // the pending passage, when passage_pending_
  bool passage_pending_{false};
  bool passage_impact_done_{false};
};

// Table acceleration of live stepping (RockingModel::Step, the stack's
// Stepper::Step): linear from (t0, a0) to (t1, a1), held constant when
// t1 == t0. Lives on the stack of Step (no allocation).
class SegmentForcing final : public Forcing {
 public:
  SegmentForcing(double t0, double a0, double t1, double a1) : t0_(t0), a0_(a0), t1_(t1), a1_(a1) {}
  double TableAcceleration(double t_s) const override {
    if (!(t1_ > t0_)) return a1_;
    const double w = (t_s - t0_) / (t1_ - t0_);
    return a0_ + w * (a1_ - a0_);
  }

 private:
  double t0_, a0_, t1_, a1_;
};

std::unique_ptr<RockingModel> MakeHousner(const BlockParams& params, const ModelOptions& options);
std::unique_ptr<RockingModel> MakeComplex(const BlockParams& params, const ModelOptions& options);

}  // namespace rocklab::model::detail
