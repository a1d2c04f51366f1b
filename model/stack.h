#pragma once
// A stack of rigid blocks rocking on a moving table, Housner-type (no
// sliding, no bounce, no flight): the dynamics of each contact mode in
// generalised coordinates, the contact loads that decide uplift, and the
// impact map. Issue 37's first piece: no integration loop and no command
// uses it yet. Derivation: docs/models.md, "Assemblies"; its independent
// reference: tests/model/oracle/stack_oracle.py.
//
// Conventions: table frame, x to the right, z up, angles counter-clockwise.
// Bodies bottom-up; interface k lies under body k (0: the table). Each
// interface is closed (0) or pivots on the left corner of its contact face
// (+1: the body above turns counter-clockwise relative to the one below) or
// on its right corner (-1). The contact face of interface k is [-c_k, c_k]
// (c_0 = b_0, c_k = min(b_k-1, b_k): centred bodies).

#include <Eigen/Core>
#include <array>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "model/cancel.h"
#include "model/rocking_model.h"

namespace rocklab::model::stack {

/// Largest number of bodies (fixed-size matrices: no allocation per call).
inline constexpr int kMaxBodies = 8;

/// A rectangular body: half sizes (m), mass (kg), moment of inertia about
/// its centre of mass (kg m^2).
struct Body {
  double half_width_m{};
  double half_height_m{};
  double mass_kg{};
  double inertia_kgm2{};
  /// A solid rectangle of these sizes and mass.
  static Body Rectangle(double width_m, double height_m, double mass_kg);
};

/// An impact's tensile impulse at an interface that its standing
/// compression (the weight above it) takes up within this time is not
/// flight (docs/models.md, "Impacts: the contact states after"), s.
inline constexpr double kContactPreloadTimeS = 1e-6;

/// Contact state per interface: 0 closed, +1 pivot left, -1 pivot right.
using Mode = std::array<int, kMaxBodies>;

using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxBodies, 1>;
using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxBodies, kMaxBodies>;

/// Normal force (N, along the lower face's normal, pushing the body above)
/// and moment (N m, counter-clockwise, about the interface's contact point:
/// the face centre when closed, the pivot corner otherwise) that the body
/// below gives the bodies above an interface.
struct Load {
  double normal_n{};
  double moment_nm{};
};

class Stack {
 public:
  /// Bottom-up; `glued`: interfaces that never open (size 0 or bodies()).
  /// Throws std::invalid_argument for no body, more than kMaxBodies, or a
  /// size, mass or inertia that is not finite and > 0.
  explicit Stack(std::vector<Body> bodies, std::vector<bool> glued = {});

  int bodies() const { return n_; }
  const Body& body(int i) const { return bodies_[static_cast<std::size_t>(i)]; }
  /// Half-width of interface k's contact face, m.
  double contact_half_width_m(int k) const { return c_[static_cast<std::size_t>(k)]; }
  bool glued(int k) const { return glued_[static_cast<std::size_t>(k)]; }

  /// Number of generalised coordinates in `mode`: its pivoting interfaces.
  int Dofs(const Mode& mode) const;
  /// Absolute angle (rad) and rate (rad/s) of every body from the relative
  /// angles q and rates qdot of the pivoting interfaces (interface order).
  void Bodies(const Mode& mode, const Vec& q, const Vec& qdot, double* theta, double* theta_dot) const;
  /// Generalised accelerations (rad/s^2) under the table's acceleration
  /// (m/s^2): Lagrange's equations M(q) qddot = f(q, qdot, u_g'').
  Vec Accelerations(const Mode& mode, const Vec& q, const Vec& qdot, double table_accel_mps2) const;
  /// The load through every interface (`loads`: bodies() values) for the
  /// motion q, qdot, qddot under that table acceleration.
  void Loads(const Mode& mode, const Vec& q, const Vec& qdot, const Vec& qddot, double table_accel_mps2,
             Load* loads) const;
  /// Kinetic plus potential energy (J), the table at rest.
  double Energy(const Mode& mode, const Vec& q, const Vec& qdot) const;

  /// After interface k's pivot closes (its relative angle 0): the
  /// post-impact contact state, solving the complementarity problem of the
  /// contacts at zero gap by trying every state, fewest contact changes first
  /// (k on its other corner, closed, or on its own corner; each closed,
  /// unglued interface kept closed or opened): the first whose impulses push
  /// (normal impulse >= 0, a closed face's impulsive moment within c times
  /// it) and whose opened interfaces move apart. Angular momentum of the
  /// bodies above every pivot is conserved about it (the inelastic impact;
  /// kinetic energy never grows); with `restitution` >= 0 interface k's
  /// relative rate is instead that factor times its rate before. When no
  /// state pushes to round-off, the one of least tensile impulse is taken if
  /// that is within every interface's preload allowance (the weight above it
  /// over kContactPreloadTimeS); failing that, the same with the interfaces
  /// that pivot through the impact held (their normal impulse not checked:
  /// no flight). docs/models.md, "Impacts: the contact states after".
  /// Throws std::runtime_error when none is.
  /// Which pass resolved an impact: every impulse pushing (the exact
  /// complementarity solution), a tension within the preloads, or pivots
  /// held (a block that would jump kept on its pivot: a model assumption,
  /// counted by Stepper and reported by simulate).
  enum class ImpactRule { kPushing, kPreload, kHeldPivots };
  struct ImpactResult {
    ImpactRule rule{ImpactRule::kPushing};
    Mode mode{};
    Vec q;     ///< the same configuration in the new mode's coordinates
    Vec qdot;  ///< rad/s
  };
  ImpactResult Impact(const Mode& mode, const Vec& q, const Vec& qdot, int k, double restitution = -1.0) const;

 private:
  struct Geometry;
  void Describe(const Mode& mode, const Vec& q, Geometry& out) const;
  std::vector<Body> bodies_;
  std::vector<double> c_;
  std::vector<bool> glued_;
  int n_{};
};

/// A rocking frame: `columns` equal rectangular columns under a rigid cap
/// beam resting on their tops (Makris and Vassiliou 2013).
struct Frame {
  int columns{2};
  double column_width_m{};
  double column_height_m{};
  double column_mass_kg{};
  double beam_mass_kg{};
};

/// The single block that moves as the frame does (docs/models.md, "The
/// rocking frame"): the columns' alpha, p_hat = p sqrt((1 + 2 gamma) / (1 +
/// 3 gamma)) and mu = (1 - 1.5 sin^2(alpha) + 3 gamma cos(2 alpha)) / (1 +
/// 3 gamma), gamma = m_beam / (N m_column). @throws std::invalid_argument
/// naming the field for a count < 1 or a size or mass not finite and > 0
/// (the beam's mass may be 0).
BlockParams FrameEquivalent(const Frame& frame);

/// How a stack is integrated and sampled.
struct RunOptions {
  double rtol{1e-10};           ///< CVODE's relative tolerance, 1
  double atol_rad{1e-12};       ///< absolute tolerance on the angles, rad (rates: x 100, rad/s)
  double rate_hz{200.0};        ///< output samples per second, Hz
  double duration_s{10.0};      ///< s, from t = 0 at rest
  double rest_step_s{1e-3};     ///< largest step while nothing moves (the table's push is looked at this often), s
  /// Per interface (bottom-up): the restitution of its impacts (relative
  /// rate after / before), or < 0 (and absent) for the angular momentum rule.
  std::vector<double> restitution;
  /// A pivot whose relative rate after an impact is below this closes
  /// (stays shut: Housner's impacts would otherwise come ever closer), rad/s.
  double rest_rate_rad_s{1e-6};
  /// How the equations are stepped: Adams, for a whole record (Simulate)
  /// and live in the model node (docs/models.md, "In the model node").
  Integrator integrator{Integrator::kAdams};
  /// Polled every kCancelPollOutputs output samples (empty: never); true
  /// stops the run with model::Cancelled (a sweep's Ctrl-C inside a case).
  CancelHook cancelled;
};

/// Output samples between two polls of RunOptions::cancelled (as a
/// sweep's single-block case polls its token).
inline constexpr long kCancelPollOutputs = 256;

/// The single block's kinds (uplift, impact, rest, overturn) and their names.
using model::EventKind;
using model::ToString;

struct Event {
  double time_s{};
  EventKind kind{};
  int interface{};  ///< 0: the table, k: under body k
  Mode after{};     ///< the contact states from then on
  /// As event_t's value, of the interface, in the single block's sign
  /// (clockwise positive): uplift the table acceleration, m/s^2; impact the
  /// interface's relative rate before, rad/s; rest 0; overturn its relative angle, rad.
  double value{};
  /// An impact's (and a rest that an impact's momentum balance closed):
  /// which pass of Stack::Impact resolved it; kPushing for other events.
  Stack::ImpactRule rule{Stack::ImpactRule::kPushing};
};

/// A stack's run: samples at t = k / rate_hz (angles counter-clockwise,
/// the stack's convention) and its events.
struct Run {
  std::vector<double> time_s;
  std::vector<std::array<double, kMaxBodies>> theta;      ///< rad, per body
  std::vector<std::array<double, kMaxBodies>> theta_dot;  ///< rad/s, per body
  std::vector<Mode> mode;
  std::vector<Event> events;
  bool overturned{false};
  long steps{};  ///< the integrator's
  /// Impacts resolved within the preloads, and with pivots held
  /// (Stack::ImpactRule): the model's assumptions, said by simulate.
  int impacts_preload{};
  int impacts_held_pivots{};
};

/// A stack stepped from rest (or from a measured state, ResetFrom), sample
/// after sample: Simulate's loop, and the model node's live run of an
/// assembly. Events, contact modes and
/// overturning as Simulate's; the state frozen once an interface overturns.
class Stepper {
 public:
  /// Only `options`' tolerances, rest step, restitution, rest rate and
  /// integrator are read. @throws std::invalid_argument for a tolerance out of range.
  Stepper(const Stack& stack, const RunOptions& options);
  ~Stepper();
  Stepper(const Stepper&) = delete;
  Stepper& operator=(const Stepper&) = delete;

  /// At rest (every interface closed) at t0_s; events cleared.
  void Reset(double t0_s);
  /// As Reset, from a measured state: every body's absolute angle (rad)
  /// and rate (rad/s), bottom-up, counter-clockwise (stack().bodies()
  /// values each). Interface k's relative angle theta_k - theta_k-1 (the
  /// table's 0 under body 0) below `rest_rad` in magnitude keeps it closed
  /// (relative angle and rate taken as 0: sensor noise opens no joint);
  /// above, it pivots on the corner that sign turns it about (> 0: left,
  /// +1) at that relative angle and rate. A rate that is not finite counts
  /// as 0 (as the single block's start). Refused, the stepper left at rest
  /// at t0_s, when no mode admits the state: an angle not finite, a glued
  /// interface open, or a relative angle at or past pi/2 (overturned).
  /// @return "" when started from the state, else why it was refused.
  /// @throws std::invalid_argument for t0_s or rest_rad not finite.
  [[nodiscard]] std::string ResetFrom(double t0_s, const double* theta, const double* theta_dot, double rest_rad);
  /// Integrates to t_s (>= time_s()) under `forcing`, evaluated only on
  /// [time_s(), horizon_s] (horizon_s >= t_s: the integrator may step past
  /// t_s and interpolate there, its history kept). Successive calls pass
  /// the same forcing. @throws std::invalid_argument for a time out of
  /// order, std::runtime_error when the integrator or an impact fails.
  void AdvanceTo(double t_s, const Forcing& forcing, double horizon_s);
  /// Live: the table acceleration (m/s^2) at t_s, linear since the
  /// previous sample (the first after Reset held constant); never evaluates
  /// the table past t_s (RockingModel::Step's rule).
  void Step(double t_s, double table_accel_mps2);

  const Stack& stack() const { return stack_; }
  double time_s() const { return t_; }
  const Mode& mode() const { return mode_; }
  /// Every body's absolute angle (rad) and rate (rad/s), bottom-up,
  /// counter-clockwise (stack().bodies() values each).
  void BodyStates(double* theta, double* theta_dot) const;
  /// Kinetic plus potential energy above rest, J.
  double EnergyAboveRest() const;
  bool overturned() const { return overturned_; }
  /// The interface that overturned (-1: none).
  int overturned_interface() const { return overturned_interface_; }
  /// Impacts since Reset, at every interface.
  int impacts() const { return impacts_; }
  /// Of those, the impacts resolved within the preloads, and with pivots
  /// held (Stack::ImpactRule), since Reset.
  int impacts_preload() const { return impacts_preload_; }
  int impacts_held_pivots() const { return impacts_held_pivots_; }
  /// Events since Reset (or the last ClearEvents).
  const std::vector<Event>& events() const { return events_; }
  void ClearEvents() { events_.clear(); }
  /// The integrator's steps since construction.
  long steps() const;

 private:
  struct Solvers;
  Stack stack_;
  RunOptions options_;
  std::unique_ptr<Solvers> solvers_;
  Mode mode_{};
  Vec q_, qdot_;
  double t_{};
  double rest_energy_j_{};
  bool reinit_{true};  // the integrator restarts at t_ in mode_ before the next step
  bool start_{true};   // the next advance is the first since a Reset: loads checked (OpenPastCorners)
  bool overturned_{};
  int overturned_interface_{-1};
  int impacts_{};
  int impacts_preload_{};
  int impacts_held_pivots_{};
  std::vector<Event> events_;
  double last_step_time_s_{}, last_step_accel_{};
  bool has_step_sample_{};
};

/// Integrates `stack` from rest under `forcing` (CVODE's Adams method; the
/// equations of the current contact mode, restarted at every change of it
/// and at the forcing's declared jumps). Stops at an overturning (an
/// interface's relative angle reaching pi/2). @throws std::invalid_argument
/// for a rate or duration out of range, std::runtime_error when the
/// integrator or an impact fails, model::Cancelled when options.cancelled
/// says stop.
Run Simulate(const Stack& stack, const Forcing& forcing, const RunOptions& options);

/// Body k alone on its base face (interface k's contact face, half-width
/// c_k): alpha = atan(c_k / h_k), p^2 = m g R / I_O with R = hypot(c_k, h_k)
/// and I_O = I + m R^2, and mu = 1 - 2 m c_k^2 / I_O (Housner's momentum
/// balance about the new corner; 1 - 1.5 sin^2(alpha) for a rectangle on
/// its own width), or the interface's restitution when given (>= 0).
BlockParams StackBodyParams(const Stack& stack, int k, const std::vector<double>& restitution);

/// A mode's name, one letter per interface bottom-up: C closed, L pivot on
/// the left corner, R on the right one ("CC": at rest, two bodies).
std::string ModeName(const Mode& mode, int interfaces);

}  // namespace rocklab::model::stack
