#include "model/rocking_model.h"

#include "common/logger_clock.h"
#include "model/model_registry.h"
#include "model/numbers.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "model/rocking_impl.h"

namespace rocklab::model {
namespace {

using detail::ExactText;
using detail::kPi;
using detail::SegmentForcing;

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> logger = common::NamedLogger("model");
  return logger;
}

}  // namespace

const char* ToString(ModelKind kind) {
  for (const ModelInfo& m : Models()) {
    if (m.kind == kind) return m.name;
  }
  return "?";
}

const char* ToString(Regime regime) {
  switch (regime) {
    case Regime::kRest: return "rest";
    case Regime::kRocking: return "rocking";
    case Regime::kOverturned: return "overturned";
  }
  return "?";
}

const char* ToString(EventKind kind) {
  switch (kind) {
    case EventKind::kUplift: return "uplift";
    case EventKind::kImpact: return "impact";
    case EventKind::kRest: return "rest";
    case EventKind::kOverturn: return "overturn";
  }
  return "?";
}

const char* ToString(Integrator integrator) {
  switch (integrator) {
    case Integrator::kAdams: return "adams";
    case Integrator::kRungeKutta: return "rk";
    case Integrator::kDormandPrince853: return "dop853";
    case Integrator::kDormandPrince5: return "dopri5";
  }
  return "?";
}

const char* ToString(Equations equations) {
  switch (equations) {
    case Equations::kHousner: return "housner";
    case Equations::kEq10: return "eq10";
    case Equations::kLimit: return "limit";
  }
  return "?";
}

ModelKind ParseModelKind(const std::string& name) {
  if (const ModelInfo* m = FindModel(name)) return m->kind;
  throw std::invalid_argument("unknown model '" + name + "' (expected " + ModelNames(", ") + ")");
}

void ModelOptions::Validate() const {
  auto bad = [](const char* name, const char* rule, double v) {
    throw std::invalid_argument(std::string("ModelOptions.") + name + " must be " + rule + " (got " +
                                ExactText(v) + ")");
  };
  if (!std::isfinite(rtol) || rtol <= 0.0 || rtol >= 1.0) bad("rtol", "in (0, 1)", rtol);
  if (!std::isfinite(atol) || atol <= 0.0) bad("atol", "finite and > 0", atol);
  if (!std::isfinite(max_step_s) || max_step_s <= 0.0) bad("max_step_s", "finite and > 0 s", max_step_s);
  if (!std::isfinite(l) || l <= 0.0) bad("l", "finite and > 0", l);
  if (!std::isfinite(complex_resolved_energy) || complex_resolved_energy < 0.0) {
    bad("complex_resolved_energy", "finite and >= 0", complex_resolved_energy);
  }
  if (!std::isfinite(rest_impact_interval_s) || rest_impact_interval_s < 0.0) {
    bad("rest_impact_interval_s", "finite and >= 0 s", rest_impact_interval_s);
  }
}

std::unique_ptr<RockingModel> RockingModel::Create(ModelKind kind, const BlockParams& params,
                                                   const ModelOptions& options) {
  params.Validate();
  options.Validate();
  return FindModel(kind).make(params, options);
}

void RockingModel::Step(double t_s, double table_accel_mps2) {
  if (!std::isfinite(t_s) || !std::isfinite(table_accel_mps2)) {
    throw std::invalid_argument("Step: t_s and table_accel_mps2 must be finite (got " + ExactText(t_s) +
                                ", " + ExactText(table_accel_mps2) + ")");
  }
  const SegmentForcing forcing = has_step_sample_
                                     ? SegmentForcing(last_step_time_s_, last_step_accel_, t_s, table_accel_mps2)
                                     : SegmentForcing(t_s, table_accel_mps2, t_s, table_accel_mps2);
  AdvanceTo(t_s, forcing);
  last_step_time_s_ = t_s;
  last_step_accel_ = table_accel_mps2;
  has_step_sample_ = true;
}

Trajectory Simulate(RockingModel& model, const Forcing& forcing, double t0_s, double theta0,
                    double theta_dot0, double duration_s, double rate_hz) {
  if (!std::isfinite(duration_s) || duration_s < 0.0) {
    throw std::invalid_argument("Simulate: duration_s must be finite and >= 0 (got " + ExactText(duration_s) + ")");
  }
  if (!std::isfinite(rate_hz) || rate_hz <= 0.0) {
    throw std::invalid_argument("Simulate: rate_hz must be finite and > 0 (got " + ExactText(rate_hz) + ")");
  }
  model.Reset(t0_s, theta0, theta_dot0);
  // The small allowance keeps e.g. 4 s * 100 Hz from losing its last sample
  // to rounding.
  const auto n = static_cast<std::size_t>(std::floor(duration_s * rate_hz * (1 + 1e-12) + 1e-9)) + 1;
  Trajectory out;
  out.time_s.reserve(n);
  out.theta.reserve(n);
  out.theta_dot.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = t0_s + static_cast<double>(k) / rate_hz;
    // No stop at the outputs: they are interpolated.
    model.AdvanceAhead(t, forcing, std::numeric_limits<double>::infinity());
    out.time_s.push_back(t);
    out.theta.push_back(model.state().theta);
    out.theta_dot.push_back(model.state().theta_dot);
  }
  out.events = model.events();
  return out;
}

namespace detail {

CvodeRockingModel::CvodeRockingModel(const BlockParams& params, const ModelOptions& options)
    : params_(params),
      options_(options),
      uplift_minus_mps2_(kGravity * std::tan(params.Side(-1).alpha)),
      uplift_plus_mps2_(kGravity * std::tan(params.Side(+1).alpha)) {
  params_.Validate();
  options_.Validate();
  events_.reserve(256);
}

void CvodeRockingModel::Init(int n, const double* atol) {
  n_ = n;
  Cvode::Method method = Cvode::Method::kAdams;
  if (options_.integrator == Integrator::kRungeKutta) method = Cvode::Method::kRungeKutta;
  if (options_.integrator == Integrator::kDormandPrince853) method = Cvode::Method::kDormandPrince853;
  if (options_.integrator == Integrator::kDormandPrince5) method = Cvode::Method::kDormandPrince5;
  cvode_ = std::make_unique<Cvode>(n, static_cast<OdeSystem&>(*this), options_.rtol, atol, options_.max_step_s,
                                   method);
  EnterRest(0.0);
}

void CvodeRockingModel::SetAbsTolerances(const double* atol) { cvode_->SetTolerances(options_.rtol, atol); }

void CvodeRockingModel::Reset(double t0_s, double theta0, double theta_dot0) {
  if (!std::isfinite(t0_s)) throw std::invalid_argument("Reset: t0_s is not finite");
  if (!std::isfinite(theta0) || std::abs(theta0) >= kPi / 2) {
    throw std::invalid_argument("Reset: theta0 must be finite with |theta0| < pi/2 (got " + ExactText(theta0) + ")");
  }
  if (!std::isfinite(theta_dot0)) {
    throw std::invalid_argument("Reset: theta_dot0 is not finite (got " + ExactText(theta_dot0) + ")");
  }
  events_.clear();
  ResetStepHistory();
  passage_pending_ = false;
  state_ = ModelState{};
  last_impact_s_ = -std::numeric_limits<double>::infinity();
  restarts_ = 0;
  rocking_time_s_ = eq10_time_s_ = 0.0;
  stats_at_reset_ = cvode_->stats();
  if (theta0 == 0.0 && theta_dot0 == 0.0) {
    EnterRest(t0_s);
    return;
  }
  const int side = theta0 > 0.0 || (theta0 == 0.0 && theta_dot0 > 0.0) ? +1 : -1;
  StartRocking(t0_s, theta0, theta_dot0, side);
}

void CvodeRockingModel::EnterRest(double t_s) {
  state_.time_s = t_s;
  state_.theta = state_.theta_dot = state_.chi = state_.psi = state_.energy = 0.0;
  state_.regime = Regime::kRest;
  state_.equations = RestEquations();
  rest_checked_ = false;
  passage_pending_ = false;
  for (double& v : y_) v = 0.0;
  cvode_->ReInit(t_s, y_);
  // Root 0: u_g'' rising through +g tan(alpha_-) (onto the -x pivot); root
  // 1: falling through -g tan(alpha_+) (onto the +x pivot); root 2 unused at
  // rest. For a symmetric block both are g tan(alpha).
  cvode_->SetRootDirection({+1, -1, +1});
}

SolverStats CvodeRockingModel::solver_stats() const {
  const Cvode::Stats now = cvode_->stats();
  SolverStats s;
  s.steps = now.steps - stats_at_reset_.steps;
  s.rhs_evals = now.rhs_evals - stats_at_reset_.rhs_evals;
  s.error_test_fails = now.error_test_fails - stats_at_reset_.error_test_fails;
  s.recoveries = now.recoveries - stats_at_reset_.recoveries;
  s.restarts = restarts_;
  s.rocking_time_s = rocking_time_s_;
  s.eq10_time_s = eq10_time_s_;
  if (rocking_time_s_ > 0.0) {
    s.eq10_fraction = eq10_time_s_ / rocking_time_s_;
  } else {
    s.eq10_fraction = RestEquations() == Equations::kEq10 ? 1.0 : 0.0;
  }
  return s;
}

Cvode::Result CvodeRockingModel::Integrate(double tout_s, double tstop_s) {
  // At rest the root functions are the forcing's: a bounded step keeps a
  // short excursion above the uplift threshold from being stepped over.
  // Rocking, the roots are the state's and the error test bounds the step
  // when the integrator may step past the output (AdvanceAhead); stopping at
  // every output (AdvanceTo, Step) keeps the cap, which changes nothing at a
  // 1 kHz sample rate and keeps those results as they were.
  const double max_step_s = state_.regime == Regime::kRest || !(tstop_s > tout_s) ? options_.max_step_s : 0.0;
  if (max_step_s != max_step_set_s_) {
    cvode_->SetMaxStep(max_step_s);
    max_step_set_s_ = max_step_s;
  }
  try {
    return cvode_->Advance(tout_s, tstop_s);
  } catch (const detail::IntegratorError& e) {
    // The integrator names its flag, time and state; the model adds itself.
    char model[160];
    std::snprintf(model, sizeof model, "%s model (alpha %.9g rad, p %.9g rad/s, mu %.9g, %s): ", ToString(kind()),
                  params_.alpha, params_.p, params_.mu, ToString(state_.regime));
    throw detail::IntegratorError(model + std::string(e.what()));
  }
}

void CvodeRockingModel::SetSegment(double t_from_s, double t_to_s) {
  const double inf = std::numeric_limits<double>::infinity();
  segment_lo_s_ = std::nextafter(t_from_s, inf);
  segment_hi_s_ = std::nextafter(t_to_s, -inf);
  if (segment_lo_s_ > segment_hi_s_) {  // a segment of two ulps or less: no clamping
    segment_lo_s_ = -inf;
    segment_hi_s_ = inf;
  }
}

void CvodeRockingModel::RestartAtDiscontinuity(double t_s) {
  ++restarts_;
  if (state_.regime == Regime::kRest) {
    rest_checked_ = false;  // the criterion is checked again on the far side
    cvode_->ReInit(t_s, y_);
    cvode_->SetRootDirection({+1, -1, +1});
  } else {
    RestartRocking(t_s);
  }
}

void CvodeRockingModel::RestartRocking(double t_s) {
  cvode_->ReInit(t_s, y_);
  cvode_->SetRootDirection({ImpactRootDirection(), +1, SwitchRootDirection()});
}

bool CvodeRockingModel::TableAllowsRest(double t_s) const {
  const double ug = table_accel(t_s);
  return ug <= uplift_minus_mps2_ && ug >= -uplift_plus_mps2_;
}

bool CvodeRockingModel::Impact(double t_s, double theta_dot) {
  ++state_.impacts;
  Emit(t_s, EventKind::kImpact, theta_dot);
  const bool rest = (t_s - last_impact_s_ < options_.rest_impact_interval_s || RestAtImpact(y_)) &&
                    TableAllowsRest(t_s);
  last_impact_s_ = t_s;
  if (!rest) return false;
  events_.back().value_after = 0.0;
  Emit(t_s, EventKind::kRest, 0.0);
  EnterRest(t_s);
  last_impact_s_ = -std::numeric_limits<double>::infinity();
  return true;
}

bool CvodeRockingModel::AdvancePassage(double t_s) {
  if (!passage_impact_done_) {
    if (t_s < passage_.t_impact_s) {
      FillPassageState(t_s);
      UpdateState(t_s);
      return false;
    }
    passage_impact_done_ = true;
    FillPassageState(passage_.t_impact_s);
    UpdateState(passage_.t_impact_s);
    if (Impact(passage_.t_impact_s, passage_.impact_theta_dot)) return true;  // at rest: passage dropped
    events_.back().value_after = passage_.after_theta_dot;
  }
  if (t_s < passage_.t_exit_s) {
    FillPassageState(t_s);
    UpdateState(t_s);
    return false;
  }
  passage_pending_ = false;
  rocking_time_s_ += passage_.t_exit_s - passage_.t_entry_s;
  eq10_time_s_ += passage_.t_exit_s - passage_.t_entry_s;
  FinishPassage(y_);
  RestartRocking(passage_.t_exit_s);
  UpdateState(passage_.t_exit_s, y_);
  return true;
}

void CvodeRockingModel::StartRocking(double t_s, double theta0, double theta_dot0, int side) {
  state_.regime = Regime::kRocking;
  InitialState(theta0, theta_dot0, side, y_);
  RestartRocking(t_s);
  UpdateState(t_s, y_);
}

void CvodeRockingModel::UpdateState(double t_s, const double* y) {
  FillState(y);
  UpdateState(t_s);
}

void CvodeRockingModel::UpdateState(double t_s) {
  state_.time_s = t_s;
  // E / (M g R) of the pivot it rocks on (at theta = 0: the one it moves onto).
  const int side = state_.theta > 0.0 || (state_.theta == 0.0 && state_.theta_dot >= 0.0) ? +1 : -1;
  const SideParams sp = params_.Side(side);
  const double a = sp.alpha;
  state_.energy = state_.theta_dot * state_.theta_dot / (2 * sp.p * sp.p) +
                  std::cos(a - std::abs(state_.theta)) - std::cos(a);
}

void CvodeRockingModel::Emit(double t_s, EventKind kind, double value) {
  events_.push_back({t_s, kind, value});
  Log()->debug("{} {} at {:.9f} s, value {:.9g}", ToString(kind), state_.impacts, t_s, value);
}

int CvodeRockingModel::Rhs(double t_s, const double* y, double* ydot) {
  if (state_.regime == Regime::kRocking) {
    RockingRhs(t_s, y, ydot);
  } else {
    for (int i = 0; i < n_; ++i) ydot[i] = 0.0;
  }
  return 0;
}

int CvodeRockingModel::Roots(double t_s, const double* y, double* g) {
  if (state_.regime == Regime::kRocking) {
    RockingRoots(y, g);
  } else {
    const double ug = table_accel(t_s);
    g[0] = ug - uplift_minus_mps2_;
    g[1] = ug + uplift_plus_mps2_;
    g[2] = 1.0;
  }
  return 0;
}

void CvodeRockingModel::AdvanceAhead(double t_s, const Forcing& forcing, double horizon_s) {
  if (!std::isfinite(t_s) || t_s < state_.time_s) {
    throw std::invalid_argument("AdvanceTo: t_s (" + ExactText(t_s) + ") is before the current time (" +
                                ExactText(state_.time_s) + ")");
  }
  if (!(horizon_s >= t_s)) {
    throw std::invalid_argument("AdvanceAhead: horizon_s (" + ExactText(horizon_s) + ") is before t_s (" +
                                ExactText(t_s) + ")");
  }
  forcing_ = &forcing;
  while (true) {
    if (state_.regime == Regime::kOverturned) {
      state_.time_s = t_s;  // the state stays frozen at the overturn
      break;
    }
    if (passage_pending_) {
      SetSegment(state_.time_s, t_s);  // the table at its impact, within this call's forcing
      if (!AdvancePassage(t_s)) break;
      continue;
    }
    // Output at t_s or at the forcing's next jump, whichever comes first; the
    // integrator never steps past the jump or the horizon (t_stop), and at a
    // jump it restarts (its history must not span it).
    const double t_jump = forcing.NextDiscontinuity(state_.time_s);
    const bool stop_at_jump = t_jump <= t_s;
    const double t_out = stop_at_jump ? t_jump : t_s;
    const double t_stop = std::min(t_jump, horizon_s);
    SetSegment(state_.time_s, t_stop);
    if (state_.regime == Regime::kRest) {
      if (!rest_checked_) {
        // Root finding sees crossings only: check the criterion where rest starts.
        rest_checked_ = true;
        const double ug = table_accel(state_.time_s);
        if (ug > uplift_minus_mps2_ || ug < -uplift_plus_mps2_) {
          Emit(state_.time_s, EventKind::kUplift, ug);
          // u_g'' > 0 pushes the block onto its -x corner (theta < 0), docs/errata.md item 5/6.
          StartRocking(state_.time_s, 0.0, 0.0, ug > 0.0 ? -1 : +1);
          continue;
        }
      }
      if (state_.time_s >= t_s) break;
      const Cvode::Result r = Integrate(t_out, t_stop);
      state_.time_s = cvode_->t_s();
      if (r == Cvode::Result::kReached) {
        if (!stop_at_jump) break;
        for (int i = 0; i < n_; ++i) y_[i] = 0.0;
        RestartAtDiscontinuity(t_out);
        continue;
      }
      const auto found = cvode_->RootsFound();
      const double t = cvode_->t_s();
      Emit(t, EventKind::kUplift, table_accel(t));
      StartRocking(t, 0.0, 0.0, found[0] != 0 ? -1 : +1);
      continue;
    }
    if (state_.time_s >= t_s) break;
    const double t_from = state_.time_s;
    const Equations equations = state_.equations;
    const Cvode::Result r = Integrate(t_out, t_stop);
    const double t = cvode_->t_s();
    rocking_time_s_ += t - t_from;
    if (equations == Equations::kEq10) eq10_time_s_ += t - t_from;
    for (int i = 0; i < n_; ++i) y_[i] = cvode_->y()[i];
    UpdateState(t, y_);
    if (r == Cvode::Result::kReached) {
      if (!stop_at_jump) break;
      RestartAtDiscontinuity(t_out);
      continue;
    }
    const auto found = cvode_->RootsFound();
    if (found[1] != 0) {
      state_.regime = Regime::kOverturned;
      Emit(t, EventKind::kOverturn, state_.theta);
      continue;
    }
    if (found[0] == 0) {
      // Only the formulation's switch root.
      const SwitchResult sw = ApplySwitch(t, y_, &passage_);
      if (sw == SwitchResult::kPassage) {
        passage_pending_ = true;
        passage_impact_done_ = false;
        continue;  // the passage carries on from t (a jump inside it is held, see Passage)
      }
      if (sw == SwitchResult::kReinit) {
        RestartRocking(t);
        UpdateState(t, y_);
      }
      if (stop_at_jump && t >= t_out) RestartAtDiscontinuity(t);
      continue;
    }
    // An impact.
    if (Impact(t, state_.theta_dot)) continue;
    const std::size_t impact_event = events_.size() - 1;
    if (ApplyImpact(y_)) {
      RestartRocking(t);
      UpdateState(t, y_);
      events_[impact_event].value_after = state_.theta_dot;
    }
    if (stop_at_jump && t >= t_out) RestartAtDiscontinuity(t);
  }
  forcing_ = nullptr;
}

}  // namespace detail
}  // namespace rocklab::model
