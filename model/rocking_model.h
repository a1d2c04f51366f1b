#pragma once
/// @file
/// Housner's piecewise model and the paper's complex formulation, integrated
/// with SUNDIALS CVODE, with the regime logic of docs/errata.md item 6 (rest, uplift,
/// impacts, return to rest, overturning).

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "model/block.h"
#include "model/excitation.h"

namespace rocklab::model {

enum class ModelKind { kHousner, kComplex };
enum class Regime { kRest, kRocking, kOverturned };
enum class EventKind { kUplift, kImpact, kRest, kOverturn };
/// The equations that produced a sample: Housner's model, the paper's
/// eq. (10) (complex formulation), or eq. (10)'s l -> 0 limit (the opt-in
/// hand-off of the complex model, ModelOptions::complex_resolved_energy).
enum class Equations { kHousner, kEq10, kLimit };

/// "housner" / "complex"; "rest" / "rocking" / "overturned";
/// "uplift" / "impact" / "rest" / "overturn".
const char* ToString(ModelKind kind);
const char* ToString(Regime regime);
const char* ToString(EventKind kind);
/// "housner" / "eq10" / "limit".
const char* ToString(Equations equations);
/// @throws std::invalid_argument for a name other than housner or complex.
ModelKind ParseModelKind(const std::string& name);

/// A discrete event of the model, with its time found by CVODE's root finding.
struct ModelEvent {
  double time_s{};    ///< s
  EventKind kind{};
  /// uplift: table acceleration, m/s^2; impact: theta_dot just before, rad/s;
  /// rest: 0; overturn: theta, rad.
  double value{};
  /// impact: theta_dot just after, rad/s (0 when the block rests there;
  /// NaN for a complex-model crossing integrated through, where theta_dot
  /// passes continuously and no before and after are apart); NaN otherwise.
  double value_after{std::numeric_limits<double>::quiet_NaN()};
};

/// The state a model reports after each advance.
struct ModelState {
  double time_s{};     ///< s
  double theta{};      ///< rocking angle, rad; > 0 about the +x corner
  double theta_dot{};  ///< rad/s
  double chi{};        ///< |theta| / alpha of its pivot (complex: the integrated modulus), 1
  double psi{};        ///< complex formulation phase, rad, in (-pi, pi] (housner: 0 for theta >= 0, pi otherwise)
  /// E / (M g R) = theta_dot^2 / (2 p^2) + cos(alpha - |theta|) - cos(alpha),
  /// with R, p, alpha of the pivot it rocks on, 1
  double energy{};
  int impacts{};       ///< impacts since Reset
  Regime regime{Regime::kRest};
  /// The equations integrated up to this sample (at rest: those the next
  /// uplift starts with).
  Equations equations{Equations::kHousner};
};

/// Work of the integrator and where the rocking time went, since Reset.
struct SolverStats {
  long steps{};             ///< CVODE internal steps
  long rhs_evals{};         ///< right-hand side evaluations
  long error_test_fails{};  ///< CVODE local error test failures
  long restarts{};          ///< restarts at discontinuities the forcing declared
  long recoveries{};        ///< restarts after CVODE gave up at an undeclared jump
  double rocking_time_s{};  ///< time spent rocking, s
  double eq10_time_s{};     ///< of which integrated by eq. (10), s
  /// eq10_time_s / rocking_time_s; 1 when nothing rocked and the model is
  /// eq. (10), 0 for Housner.
  double eq10_fraction{};
};

/// Default l: eq. (10)'s l -> 0 oracles hold at it to 4 digits (docs/models.md,
/// "Choosing l"; 1e-10 before issue 32).
inline constexpr double kDefaultL = 1e-14;

/// How the equations are stepped.
enum class Integrator {
  /// CVODE's Adams-Moulton: high order, its history carried from step to
  /// step; the cheapest where the forcing is smooth (Simulate).
  kAdams,
  /// ARKODE's explicit Runge-Kutta (order 5): one step at a time, so a kink
  /// of the forcing where it stops (every sample of Step's chord) costs it
  /// nothing (docs/performance.md, "Work and precision").
  kRungeKutta,
  /// Dormand and Prince's 8(5,3) with its order-7 dense output, written for
  /// the small state (model/dop853.h): far fewer right-hand sides than
  /// either where the forcing is smooth, and no library bookkeeping per
  /// step; Simulate's Housner model (docs/performance.md, "Issue 33").
  kDormandPrince853,
  /// Dormand and Prince's 5(4) with its order-4 dense output, in the same
  /// fixed arrays: the model node's, which stops at every 1 ms sample
  /// (one step of six right-hand sides a sample; docs/performance.md,
  /// "Issue 33, third round").
  kDormandPrince5,
};
/// "adams" / "rk" / "dop853" / "dopri5".
const char* ToString(Integrator integrator);

/// Housner's impact root: theta shifted by this towards the side the block
/// rocks on, rad (the CVODE model's RockingRoots and SampleFreeHousner).
inline constexpr double kHousnerImpactSlackRad = 1e-14;

/// Integration and regime knobs.
struct ModelOptions {
  double rtol{1e-10};       ///< CVODE relative tolerance, 1
  /// CVODE absolute tolerance on theta (rad) and theta_dot (rad/s); the
  /// complex model uses at most 1e-7 l on its (x, y) plane, where a crossing
  /// passes the origin at the distance ~ l.
  double atol{1e-12};
  /// Largest CVODE step, s, at rest (keeps uplift crossings of the forcing
  /// from being stepped over) and in AdvanceTo / Step (whose outputs, every
  /// sample, bound the step anyway). While rocking under AdvanceAhead
  /// (Simulate) the error test alone bounds it: the root functions are then
  /// the state's, and the cap only cost steps (docs/performance.md).
  double max_step_s{1e-3};
  double l{kDefaultL};      ///< complex formulation: normalised conjugate momentum of psi, 1; > 0
  /// Complex formulation, opt-in approximation (0, the default: off, eq. (10)
  /// throughout). K > 0: below K V_min, V_min ~ l^(2/3) the floor of eq.
  /// (10)'s regularised energy, the model integrates eq. (10)'s l -> 0 limit
  /// (Housner's equations) instead, starting there at uplift and going back
  /// to eq. (10) above K V_min (and to the limit at a crossing below K V_min
  /// / 2). 1; >= 0.
  double complex_resolved_energy{0.0};
  /// Return to rest when two impacts come closer than this, s.
  double rest_impact_interval_s{2e-3};
  Integrator integrator{Integrator::kAdams};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// A rocking model. Not copyable; owns its CVODE memory.
class RockingModel {
 public:
  /// @throws std::invalid_argument for invalid parameters or options.
  static std::unique_ptr<RockingModel> Create(ModelKind kind, const BlockParams& params,
                                              const ModelOptions& options = {});
  virtual ~RockingModel() = default;
  RockingModel(const RockingModel&) = delete;
  RockingModel& operator=(const RockingModel&) = delete;

  /// Start at t0_s from theta0 (rad) and theta_dot0 (rad/s). Both zero: at rest,
  /// waiting for the uplift criterion |u_g''| > g tan(alpha) (asymmetric
  /// section: alpha of the side it lifts onto, u_g'' > 0 tipping it onto -x).
  /// @throws std::invalid_argument when |theta0| >= pi/2 or a value is not finite.
  virtual void Reset(double t0_s, double theta0, double theta_dot0) = 0;

  /// Integrate to t_s (>= the current time), with the table acceleration from
  /// `forcing`, which is evaluated only on [current time, t_s]. Events found on
  /// the way are appended to events().
  /// @throws std::runtime_error when CVODE fails (naming the CVODE function).
  virtual void AdvanceTo(double t_s, const Forcing& forcing) = 0;

  /// As AdvanceTo, but `forcing` may be evaluated up to horizon_s (>= t_s;
  /// +infinity: anywhere): the integrator steps across t_s without stopping
  /// there and the state at t_s is its interpolant (CVodeGetDky), so its
  /// error control and step size carry over from one output to the next.
  /// Successive calls must pass the same forcing (the part before the
  /// horizon is already integrated). Simulate uses it with no horizon.
  /// @throws as AdvanceTo.
  virtual void AdvanceAhead(double t_s, const Forcing& forcing, double horizon_s) = 0;

  /// Live stepping: the table acceleration sample `table_accel_mps2` (m/s^2)
  /// at t_s; between the previous sample and this one the acceleration is
  /// linear (the first sample after Reset holds it constant). Never evaluates
  /// the forcing past t_s: a complex-model crossing solved in closed form that
  /// ends after t_s (it lasts ~1e-3 v / p s) holds the table at t_s there.
  void Step(double t_s, double table_accel_mps2);

  virtual const ModelState& state() const = 0;
  virtual ModelKind kind() const = 0;
  virtual const BlockParams& params() const = 0;
  virtual const ModelOptions& options() const = 0;
  /// Solver work and the share of eq. (10), since Reset.
  virtual SolverStats solver_stats() const = 0;

  /// Events since Reset (or since the last ClearEvents).
  const std::vector<ModelEvent>& events() const { return events_; }
  void ClearEvents() { events_.clear(); }

 protected:
  RockingModel() = default;
  /// Forgets the previous Step sample, so the next Step holds its sample
  /// constant. Every Reset implementation calls it.
  void ResetStepHistory() { has_step_sample_ = false; }
  std::vector<ModelEvent> events_;

 private:
  double last_step_time_s_{};
  double last_step_accel_{};
  bool has_step_sample_{false};
};

/// A whole simulated record at a fixed output rate.
struct Trajectory {
  std::vector<double> time_s;     ///< s
  std::vector<double> theta;      ///< rad
  std::vector<double> theta_dot;  ///< rad/s
  std::vector<ModelEvent> events;
};

/// Batch interface: Reset(t0, theta0, theta_dot0), then output at
/// t0 + k / rate_hz for k = 0 .. floor(duration_s * rate_hz).
/// @throws std::invalid_argument for duration_s < 0 or rate_hz <= 0.
Trajectory Simulate(RockingModel& model, const Forcing& forcing, double t0_s, double theta0,
                    double theta_dot0, double duration_s, double rate_hz);

}  // namespace rocklab::model
