// Integration of a stack of blocks (model/stack.h): one CVODE per number of
// equations, the roots of the current contact mode, its changes as events.
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "common/units.h"
#include "model/cvode.h"
#include "model/excitation.h"
#include "model/stack.h"

namespace rocklab::model::stack {

std::string ModeName(const Mode& mode, int interfaces) {
  std::string name;
  for (int k = 0; k < interfaces; ++k) {
    const int s = mode[static_cast<std::size_t>(k)];
    name += s == 0 ? 'C' : (s > 0 ? 'L' : 'R');
  }
  return name;
}

namespace {

// The equations and roots of one contact mode. y = (q, q') of its m
// pivots; with none (the stack at rest) one dummy equation y' = 0. Two root
// slots per interface, all falling through zero: closed, the resultant
// reaching its right (c N - M) and left (c N + M) corner; pivoting, its
// relative angle returning to 0 (s q) and reaching pi/2 (pi/2 - s q).
class ModeOde final : public detail::OdeSystem {
 public:
  ModeOde(const Stack& stack, const Forcing& forcing) : stack_(stack), forcing_(forcing) {}
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
    const Vec a = stack_.Accelerations(mode_, q_, qdot_, forcing_.TableAcceleration(t_s));
    for (int i = 0; i < m_; ++i) {
      ydot[i] = y[m_ + i];
      ydot[m_ + i] = a(i);
    }
    return 0;
  }

  int Roots(double t_s, const double* y, double* g) override {
    Split(y);
    const double accel = forcing_.TableAcceleration(t_s);
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
  const Forcing& forcing_;
  Mode mode_{};
  int m_{};
  Vec q_, qdot_;
};

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

}  // namespace

Run Simulate(const Stack& stack, const Forcing& forcing, const RunOptions& options) {
  if (!(options.rate_hz > 0 && std::isfinite(options.rate_hz))) throw std::invalid_argument("stack: rate_hz must be > 0");
  if (!(options.duration_s >= 0 && std::isfinite(options.duration_s))) {
    throw std::invalid_argument("stack: duration_s must be >= 0");
  }
  const int n = stack.bodies();
  ModeOde ode(stack, forcing);
  std::array<std::unique_ptr<detail::Cvode>, kMaxBodies + 1> solvers;  // by number of pivots
  auto solver = [&](int m) -> detail::Cvode& {
    auto& s = solvers[static_cast<std::size_t>(m)];
    if (!s) {
      const int eq = std::max(1, 2 * m);
      std::array<double, detail::Cvode::kMaxEquations> atol{};
      for (int i = 0; i < eq; ++i) atol[static_cast<std::size_t>(i)] = i < m || m == 0 ? options.atol_rad : 100 * options.atol_rad;
      s = std::make_unique<detail::Cvode>(eq, ode, options.rtol, atol.data(), m == 0 ? options.rest_step_s : 0.0,
                                          detail::Cvode::Method::kAdams, 2 * n);
      std::array<int, detail::Cvode::kMaxRoots> down{};
      down.fill(-1);
      s->SetRootDirection(down.data());
    }
    return *s;
  };
  auto restitution = [&](int k) {
    return static_cast<std::size_t>(k) < options.restitution.size() ? options.restitution[static_cast<std::size_t>(k)]
                                                                      : -1.0;
  };

  Run run;
  Mode mode{};
  Vec q(0), qdot(0);
  const long samples = static_cast<long>(std::floor(options.duration_s * options.rate_hz + 1e-9)) + 1;
  long next = 0;
  double t = 0.0;
  auto record = [&](double at) {
    std::array<double, kMaxBodies> th{}, thd{};
    stack.Bodies(mode, q, qdot, th.data(), thd.data());
    run.time_s.push_back(at);
    run.theta.push_back(th);
    run.theta_dot.push_back(thd);
    run.mode.push_back(mode);
  };
  record(0.0);
  next = 1;
  while (next < samples) {
    ode.Set(mode);
    const int m = ode.m();
    detail::Cvode& cv = solver(m);
    std::array<double, detail::Cvode::kMaxEquations> y0{};
    for (int i = 0; i < m; ++i) {
      y0[static_cast<std::size_t>(i)] = q(i);
      y0[static_cast<std::size_t>(m + i)] = qdot(i);
    }
    cv.ReInit(t, y0.data());
    bool changed = false;
    while (next < samples && !changed) {
      const double tout = static_cast<double>(next) / options.rate_hz;
      const double tstop = std::min(forcing.NextDiscontinuity(t), options.duration_s);
      const auto result = cv.Advance(std::min(tout, tstop), tstop);
      t = cv.t_s();
      const double* y = cv.y();
      for (int i = 0; i < m; ++i) {
        q(i) = y[i];
        qdot(i) = y[m + i];
      }
      if (result == detail::Cvode::Result::kReached) {
        if (t >= tout) {
          record(tout);
          if (++next % kCancelPollOutputs == 0) ThrowIfCancelled(options.cancelled);
        } else {
          changed = true;  // a jump of the forcing: restart on its other side
        }
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
      changed = true;
      if (mode[kk] == 0) {
        Insert(mode, k, q, qdot);
        mode[kk] = slot % 2 == 0 ? -1 : 1;  // the resultant at the right corner: turning clockwise on it
        run.events.push_back({t, EventKind::kUplift, k, mode});
      } else if (slot % 2 == 1) {
        run.events.push_back({t, EventKind::kOverturn, k, mode});
        run.overturned = true;
        next = samples;
      } else {
        // The striking pivot's relative angle is 0 at the root (CVODE's
        // interpolant leaves ~1e-15 rad): exactly 0 for the new contacts.
        const int dof = DofOf(mode, k);
        q(dof) = 0.0;
        if (std::abs(qdot(dof)) < options.rest_rate_rad_s || mode[kk] * qdot(dof) >= 0) {
          // Closing at (about) no relative rate, or grazing (the root found
          // in the noise of an angle that hovers at 0): no impulse; it shuts.
          Shut(k, dof, mode, q, qdot);
          run.events.push_back({t, EventKind::kRest, k, mode});
          continue;
        }
        Stack::ImpactResult after;
        try {
          after = stack.Impact(mode, q, qdot, k, restitution(k));
        } catch (const std::runtime_error& e) {
          throw std::runtime_error("at " + std::to_string(t) + " s: " + e.what());
        }
        const int new_dof = DofOf(after.mode, k);
        if (after.mode[kk] != 0 && std::abs(after.qdot(new_dof)) < options.rest_rate_rad_s) {
          // Too slow to lift again: shut, its rate taken out by the impact.
          after = stack.Impact(mode, q, qdot, k, 0.0);
          mode = after.mode;
          q = after.q;
          qdot = after.qdot;
          if (mode[kk] != 0) Shut(k, DofOf(mode, k), mode, q, qdot);  // its contacts below k may differ
          run.events.push_back({t, EventKind::kRest, k, mode});
        } else {
          mode = after.mode;
          q = after.q;
          qdot = after.qdot;
          run.events.push_back({t, EventKind::kImpact, k, mode});
        }
      }
    }
  }
  for (const auto& s : solvers) {
    if (s) run.steps += s->stats().steps;
  }
  return run;
}

}  // namespace rocklab::model::stack
