// Integration of a stack of blocks (model/stack.h): one CVODE per number of
// equations, the roots of the current contact mode, its changes as events.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "common/units.h"
#include "model/cvode.h"
#include "model/excitation.h"
#include "model/rocking_impl.h"
#include "model/stack.h"

namespace rocklab::model::stack {

BlockParams StackBodyParams(const Stack& stack, int k, const std::vector<double>& restitution) {
  const Body& b = stack.body(k);
  const double c = stack.contact_half_width_m(k);
  const double r = std::hypot(c, b.half_height_m);
  const double inertia = b.inertia_kgm2 + b.mass_kg * r * r;
  BlockParams out;
  out.alpha = std::atan2(c, b.half_height_m);
  out.p = std::sqrt(b.mass_kg * kGravity * r / inertia);
  const auto kk = static_cast<std::size_t>(k);
  out.mu = kk < restitution.size() && restitution[kk] >= 0 ? restitution[kk] : 1.0 - 2 * b.mass_kg * c * c / inertia;
  return out;
}

std::string ModeName(const Mode& mode, int interfaces) {
  std::string name;
  for (int k = 0; k < interfaces; ++k) {
    const int s = mode[static_cast<std::size_t>(k)];
    name += s == 0 ? 'C' : (s > 0 ? 'L' : 'R');
  }
  return name;
}

// Private to this file; named (not anonymous) because Stepper::Solvers holds one.
namespace run_detail {

// The equations and roots of one contact mode. y = (q, q') of its m
// pivots; with none (the stack at rest) one dummy equation y' = 0. Two root
// slots per interface, all falling through zero: closed, the resultant
// reaching its right (c N - M) and left (c N + M) corner; pivoting, its
// relative angle returning to 0 (s q) and reaching pi/2 (pi/2 - s q).
class ModeOde final : public detail::OdeSystem {
 public:
  explicit ModeOde(const Stack& stack) : stack_(stack) {}
  // The table's acceleration of the calls to come (not owned).
  void SetForcing(const Forcing& forcing) { forcing_ = &forcing; }
  void Set(const Mode& mode) {
    mode_ = mode;
    m_ = stack_.Dofs(mode);
  }
  int m() const { return m_; }

  int Rhs(double t_s, const double* y, double* ydot) override {
    if (m_ == 0) {
      ydot[0] = 0.0;
      return 0;
    }
    Split(y);
    const Vec a = stack_.Accelerations(mode_, q_, qdot_, forcing_->TableAcceleration(t_s));
    for (int i = 0; i < m_; ++i) {
      ydot[i] = y[m_ + i];
      ydot[m_ + i] = a(i);
    }
    return 0;
  }

  int Roots(double t_s, const double* y, double* g) override {
    Split(y);
    const double accel = forcing_->TableAcceleration(t_s);
    bool loads_done = false;
    std::array<Load, kMaxBodies> loads{};
    for (int k = 0, dof = 0; k < stack_.bodies(); ++k) {
      const int s = mode_[static_cast<std::size_t>(k)];
      double* slot = g + 2 * k;
      if (s != 0) {
        const double rel = s * q_(dof++);
        slot[0] = rel;
        slot[1] = common::kPi / 2 - rel;
      } else if (stack_.glued(k)) {
        slot[0] = slot[1] = 1.0;
      } else {
        if (!loads_done) {
          const Vec a = m_ > 0 ? stack_.Accelerations(mode_, q_, qdot_, accel) : Vec();
          stack_.Loads(mode_, q_, qdot_, a, accel, loads.data());
          loads_done = true;
        }
        const double c = stack_.contact_half_width_m(k);
        const Load& l = loads[static_cast<std::size_t>(k)];
        slot[0] = c * l.normal_n - l.moment_nm;
        slot[1] = c * l.normal_n + l.moment_nm;
      }
    }
    return 0;
  }

 private:
  void Split(const double* y) {
    q_.resize(m_);
    qdot_.resize(m_);
    for (int i = 0; i < m_; ++i) {
      q_(i) = y[i];
      qdot_(i) = y[m_ + i];
    }
  }
  const Stack& stack_;
  const Forcing* forcing_{};
  Mode mode_{};
  int m_{};
  Vec q_, qdot_;
};

}  // namespace run_detail

namespace {

// Index of interface k's generalised coordinate in `mode`: its pivots below k.
int DofOf(const Mode& mode, int k) {
  int dof = 0;
  for (int j = 0; j < k; ++j) dof += mode[static_cast<std::size_t>(j)] != 0;
  return dof;
}

// q, q' with a new coordinate 0, 0 for interface k (it just opened).
void Insert(const Mode& before, int k, Vec& q, Vec& qdot) {
  const int at = DofOf(before, k);
  const Eigen::Index m = q.size();
  Vec nq(m + 1), nqd(m + 1);
  nq << q.head(at), 0.0, q.tail(m - at);
  nqd << qdot.head(at), 0.0, qdot.tail(m - at);
  q = nq;
  qdot = nqd;
}

// Interface k (generalised coordinate `dof`) closed: its coordinate out.
void Shut(int k, Eigen::Index dof, Mode& mode, Vec& q, Vec& qdot) {
  mode[static_cast<std::size_t>(k)] = 0;
  Vec nq(q.size() - 1), nqd(qdot.size() - 1);
  for (Eigen::Index i = 0, o = 0; i < q.size(); ++i) {
    if (i == dof) continue;
    nq(o) = q(i);
    nqd(o++) = qdot(i);
  }
  q = nq;
  qdot = nqd;
}

detail::Cvode::Method StackMethod(Integrator integrator) {
  switch (integrator) {
    case Integrator::kAdams: return detail::Cvode::Method::kAdams;
    case Integrator::kRungeKutta: return detail::Cvode::Method::kRungeKutta;
    case Integrator::kDormandPrince853: return detail::Cvode::Method::kDormandPrince853;
    case Integrator::kDormandPrince5: return detail::Cvode::Method::kDormandPrince5;
  }
  return detail::Cvode::Method::kAdams;
}

}  // namespace

// The integrators of the stepper, one per number of pivots (created when
// a mode first needs it), and the equations they step.
struct Stepper::Solvers {
  explicit Solvers(const Stack& stack) : ode(stack) {}
  run_detail::ModeOde ode;
  std::array<std::unique_ptr<detail::Cvode>, kMaxBodies + 1> by_pivots;
};

Stepper::Stepper(const Stack& stack, const RunOptions& options)
    : stack_(stack), options_(options), solvers_(std::make_unique<Solvers>(stack_)) {
  if (!(options.rtol > 0 && options.rtol < 1) || !(options.atol_rad > 0 && std::isfinite(options.atol_rad)) ||
      !(options.rest_step_s > 0 && std::isfinite(options.rest_step_s))) {
    throw std::invalid_argument("stack: rtol must be in (0, 1), atol_rad and rest_step_s finite and > 0");
  }
  Reset(0.0);
  rest_energy_j_ = stack_.Energy(mode_, q_, qdot_);
}

Stepper::~Stepper() = default;

void Stepper::Reset(double t0_s) {
  if (!std::isfinite(t0_s)) throw std::invalid_argument("stack: Reset: t0_s is not finite");
  mode_ = Mode{};
  q_.resize(0);
  qdot_.resize(0);
  t_ = t0_s;
  reinit_ = true;
  start_ = true;
  overturned_ = false;
  overturned_interface_ = -1;
  impacts_ = 0;
  impacts_preload_ = 0;
  impacts_held_pivots_ = 0;
  events_.clear();
  has_step_sample_ = false;
}

std::string Stepper::ResetFrom(double t0_s, const double* theta, const double* theta_dot, double rest_rad) {
  if (!(std::isfinite(rest_rad) && rest_rad >= 0)) throw std::invalid_argument("stack: ResetFrom: rest_rad out of range");
  Reset(t0_s);
  const int n = stack_.bodies();
  Mode mode{};
  Vec q(n), qdot(n);  // at most kMaxBodies: no allocation
  int m = 0;
  double below = 0.0, below_rate = 0.0;  // the table's
  for (int k = 0; k < n; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (!std::isfinite(theta[kk])) return "body " + std::to_string(k + 1) + "'s angle is not finite";
    const double rate = std::isfinite(theta_dot[kk]) ? theta_dot[kk] : 0.0;
    const double rel = theta[kk] - below;
    if (std::abs(rel) >= rest_rad) {
      char what[160];
      if (stack_.glued(k)) {
        std::snprintf(what, sizeof what, "interface %d is glued but turned by %.6g rad", k, rel);
        return what;
      }
      if (std::abs(rel) >= common::kPi / 2) {
        std::snprintf(what, sizeof what, "interface %d turned by %.6g rad, at or past overturning (pi/2)", k, rel);
        return what;
      }
      mode[kk] = rel > 0 ? 1 : -1;
      q(m) = rel;
      qdot(m) = rate - below_rate;
      ++m;
    }
    below = theta[kk];
    below_rate = rate;
  }
  mode_ = mode;
  q_ = q.head(m);
  qdot_ = qdot.head(m);
  return {};
}

void Stepper::BodyStates(double* theta, double* theta_dot) const {
  stack_.Bodies(mode_, q_, qdot_, theta, theta_dot);
}

double Stepper::EnergyAboveRest() const { return stack_.Energy(mode_, q_, qdot_) - rest_energy_j_; }

long Stepper::steps() const {
  long steps = 0;
  for (const auto& s : solvers_->by_pivots) {
    if (s) steps += s->stats().steps;
  }
  return steps;
}

void Stepper::Step(double t_s, double table_accel_mps2) {
  if (!std::isfinite(t_s) || !std::isfinite(table_accel_mps2)) {
    throw std::invalid_argument("stack: Step: t_s and table_accel_mps2 must be finite");
  }
  const detail::SegmentForcing forcing =
      has_step_sample_ ? detail::SegmentForcing(last_step_time_s_, last_step_accel_, t_s, table_accel_mps2)
                       : detail::SegmentForcing(t_s, table_accel_mps2, t_s, table_accel_mps2);
  AdvanceTo(t_s, forcing, t_s);
  last_step_time_s_ = t_s;
  last_step_accel_ = table_accel_mps2;
  has_step_sample_ = true;
}

void Stepper::AdvanceTo(double t_s, const Forcing& forcing, double horizon_s) {
  if (!(t_s >= t_) || !std::isfinite(t_s) || !(horizon_s >= t_s)) {
    throw std::invalid_argument("stack: AdvanceTo: t_s must be finite, >= the current time and <= horizon_s");
  }
  if (overturned_ || t_s == t_) {
    t_ = t_s;  // frozen at the overturning, or already there (the first sample)
    return;
  }
  const int n = stack_.bodies();
  run_detail::ModeOde& ode = solvers_->ode;
  ode.SetForcing(forcing);
  auto solver = [&](int m) -> detail::Cvode& {
    auto& s = solvers_->by_pivots[static_cast<std::size_t>(m)];
    if (!s) {
      const int eq = std::max(1, 2 * m);
      std::array<double, detail::Cvode::kMaxEquations> atol{};
      for (int i = 0; i < eq; ++i) {
        atol[static_cast<std::size_t>(i)] = i < m || m == 0 ? options_.atol_rad : 100 * options_.atol_rad;
      }
      s = std::make_unique<detail::Cvode>(eq, ode, options_.rtol, atol.data(), m == 0 ? options_.rest_step_s : 0.0,
                                          StackMethod(options_.integrator), 2 * n);
      std::array<int, detail::Cvode::kMaxRoots> down{};
      down.fill(-1);
      s->SetRootDirection(down.data());
    }
    return *s;
  };
  auto restitution = [&](int k) {
    return static_cast<std::size_t>(k) < options_.restitution.size()
               ? options_.restitution[static_cast<std::size_t>(k)]
               : -1.0;
  };
  Mode& mode = mode_;
  Vec& q = q_;
  Vec& qdot = qdot_;
  double& t = t_;
  // The integrator's state (q, qdot) of the current mode's m coordinates.
  auto state = [&](int m) {
    std::array<double, detail::Cvode::kMaxEquations> y{};
    for (int i = 0; i < m; ++i) {
      y[static_cast<std::size_t>(i)] = q(i);
      y[static_cast<std::size_t>(m + i)] = qdot(i);
    }
    return y;
  };
  while (true) {
    ode.Set(mode);
    const int m = ode.m();
    if (start_) {
      // A start (at rest, or a measured mode) whose closed interface
      // already carries its load past a corner: no root falls through
      // zero there, so that joint would stay shut under a table that
      // lifts it. It opens at once, as at its uplift root, the lowest
      // first, until every closed joint's load is within its face.
      std::array<double, detail::Cvode::kMaxRoots> g{};
      ode.Roots(t, state(m).data(), g.data());
      int slot = 0;
      while (slot < 2 * n && !(mode[static_cast<std::size_t>(slot / 2)] == 0 && g[static_cast<std::size_t>(slot)] < 0)) {
        ++slot;
      }
      if (slot < 2 * n) {
        const int k = slot / 2;
        Insert(mode, k, q, qdot);
        mode[static_cast<std::size_t>(k)] = slot % 2 == 0 ? -1 : 1;  // as at the uplift root below
        events_.push_back({t, EventKind::kUplift, k, mode, forcing.TableAcceleration(t)});
        reinit_ = true;
        continue;
      }
      start_ = false;
    }
    detail::Cvode& cv = solver(m);
    if (reinit_) {
      cv.ReInit(t, state(m).data());
      reinit_ = false;
    }
    const double tstop = std::min(forcing.NextDiscontinuity(t), horizon_s);
    const auto result = cv.Advance(std::min(t_s, tstop), tstop);
    t = cv.t_s();
    const double* y = cv.y();
    for (int i = 0; i < m; ++i) {
      q(i) = y[i];
      qdot(i) = y[m + i];
    }
    if (result == detail::Cvode::Result::kReached) {
      if (t >= t_s) return;
      reinit_ = true;  // a jump of the forcing: restart on its other side
      continue;
    }
    // A root: the lowest interface's first.
    std::array<int, detail::Cvode::kMaxRoots> found{};
    cv.RootsFound(found.data());
    int slot = 0;
    while (slot < 2 * n && found[static_cast<std::size_t>(slot)] == 0) ++slot;
    if (slot == 2 * n) continue;
    const int k = slot / 2;
    const auto kk = static_cast<std::size_t>(k);
    reinit_ = true;
    if (mode[kk] == 0) {
      Insert(mode, k, q, qdot);
      mode[kk] = slot % 2 == 0 ? -1 : 1;  // the resultant at the right corner: turning clockwise on it
      events_.push_back({t, EventKind::kUplift, k, mode, forcing.TableAcceleration(t)});
    } else if (slot % 2 == 1) {
      events_.push_back({t, EventKind::kOverturn, k, mode, 0.0 - q(DofOf(mode, k))});
      overturned_ = true;
      overturned_interface_ = k;
      return;
    } else {
      // The striking pivot's relative angle is 0 at the root (CVODE's
      // interpolant leaves ~1e-15 rad): exactly 0 for the new contacts.
      const int dof = DofOf(mode, k);
      q(dof) = 0.0;
      const double rate_before = 0.0 - qdot(dof);  // the single block's sign
      if (std::abs(qdot(dof)) < options_.rest_rate_rad_s || mode[kk] * qdot(dof) >= 0) {
        // Closing at (about) no relative rate, or grazing (the root found
        // in the noise of an angle that hovers at 0): no impulse; it shuts.
        Shut(k, dof, mode, q, qdot);
        events_.push_back({t, EventKind::kRest, k, mode});
        continue;
      }
      ++impacts_;
      Stack::ImpactResult after;
      try {
        after = stack_.Impact(mode, q, qdot, k, restitution(k));
      } catch (const std::runtime_error& e) {
        throw std::runtime_error("at " + std::to_string(t) + " s: " + e.what());
      }
      const Stack::ImpactRule rule = after.rule;  // the counted pass (a shut below re-solves at restitution 0)
      impacts_preload_ += after.rule == Stack::ImpactRule::kPreload ? 1 : 0;
      impacts_held_pivots_ += after.rule == Stack::ImpactRule::kHeldPivots ? 1 : 0;
      const int new_dof = DofOf(after.mode, k);
      if (after.mode[kk] != 0 && std::abs(after.qdot(new_dof)) < options_.rest_rate_rad_s) {
        // Too slow to lift again: shut, its rate taken out by the impact.
        after = stack_.Impact(mode, q, qdot, k, 0.0);
        mode = after.mode;
        q = after.q;
        qdot = after.qdot;
        if (mode[kk] != 0) Shut(k, DofOf(mode, k), mode, q, qdot);  // its contacts below k may differ
        events_.push_back({t, EventKind::kRest, k, mode, 0.0, rule});
      } else {
        mode = after.mode;
        q = after.q;
        qdot = after.qdot;
        events_.push_back({t, EventKind::kImpact, k, mode, rate_before, rule});
      }
    }
  }
}

Run Simulate(const Stack& stack, const Forcing& forcing, const RunOptions& options) {
  if (!(options.rate_hz > 0 && std::isfinite(options.rate_hz))) throw std::invalid_argument("stack: rate_hz must be > 0");
  if (!(options.duration_s >= 0 && std::isfinite(options.duration_s))) {
    throw std::invalid_argument("stack: duration_s must be >= 0");
  }
  Stepper stepper(stack, options);
  Run run;
  const long samples = static_cast<long>(std::floor(options.duration_s * options.rate_hz + 1e-9)) + 1;
  auto record = [&](double at) {
    std::array<double, kMaxBodies> th{}, thd{};
    stepper.BodyStates(th.data(), thd.data());
    run.time_s.push_back(at);
    run.theta.push_back(th);
    run.theta_dot.push_back(thd);
    run.mode.push_back(stepper.mode());
  };
  record(0.0);
  for (long next = 1; next < samples; ++next) {
    const double tout = static_cast<double>(next) / options.rate_hz;
    stepper.AdvanceTo(tout, forcing, options.duration_s);
    if (stepper.overturned()) break;
    record(tout);
    if ((next + 1) % kCancelPollOutputs == 0) ThrowIfCancelled(options.cancelled);
  }
  run.events = stepper.events();
  run.overturned = stepper.overturned();
  run.steps = stepper.steps();
  run.impacts_preload = stepper.impacts_preload();
  run.impacts_held_pivots = stepper.impacts_held_pivots();
  return run;
}

}  // namespace rocklab::model::stack
