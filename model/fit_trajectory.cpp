// The trajectory method: alpha, p, mu (and a release time) by least squares
// of a Housner run against every theta sample, free or forced
// (FitTrajectory).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "model/excitation.h"
#include "model/fit_impl.h"
#include "model/rocking_model.h"

namespace rocklab::model {
using namespace fit_detail;
namespace {

// Residuals theta_model(t_k) - theta_k over the samples [first, n) for
// x = (alpha, p, mu[, release time]). Before a fitted release the model
// holds at the release level.
struct TrajectoryFunctor : Eigen::DenseFunctor<double> {
  TrajectoryFunctor(const RockingRecord& record, std::size_t first, const Forcing& forcing,
                    bool from_hold, double theta0, double rtol)
      : Eigen::DenseFunctor<double>(from_hold ? 4 : 3, static_cast<int>(record.size() - first)),
        record_(&record),
        first_(first),
        forcing_(&forcing),
        from_hold_(from_hold),
        theta0_(theta0) {
    model_options_.rtol = rtol;
    model_options_.atol = 1e-10;
  }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    ++*count_;
    BlockParams bp;
    bp.alpha = std::clamp(x(0), 1e-4, kPi / 2 - 1e-3);
    bp.p = std::max(x(1), 0.05);
    bp.mu = std::clamp(x(2), 0.05, 1.0);
    const double penalty =
        std::abs(bp.alpha - x(0)) + std::abs(bp.p - x(1)) / 10 + std::abs(bp.mu - x(2));
    const std::vector<double>& t = record_->time_s;
    const std::vector<double>& th = record_->theta;
    try {
      auto model = RockingModel::Create(ModelKind::kHousner, bp, model_options_);
      std::size_t k = first_;
      if (from_hold_) {
        const double tr = x(3);
        for (; k < t.size() && t[k] <= tr; ++k) f(static_cast<Eigen::Index>(k - first_)) = theta0_ - th[k];
        model->Reset(tr, theta0_, 0.0);
      } else {
        model->Reset(t[first_], 0.0, 0.0);
      }
      for (; k < t.size(); ++k) {
        model->AdvanceTo(t[k], *forcing_);
        f(static_cast<Eigen::Index>(k - first_)) = model->state().theta - th[k] + penalty;
      }
    } catch (const std::exception&) {
      f.setConstant(1.0);  // a failed run: a step LM must reject
    }
    return 0;
  }
  int evaluations() const { return *count_; }

  const RockingRecord* record_;  // non-owning; outlives the fit
  std::size_t first_;
  const Forcing* forcing_;  // non-owning; outlives the fit
  bool from_hold_;
  double theta0_;
  ModelOptions model_options_;
  std::shared_ptr<int> count_ = std::make_shared<int>(0);  // shared: NumericalDiff copies the functor
};

// A table-acceleration record as a C1 cubic Hermite through its samples
// (slopes (a[k+1] - a[k-1]) / (t[k+1] - t[k-1]), one-sided at the ends),
// zero outside: the chord's comparison interpolant.
class CubicRecord final : public Forcing {
 public:
  CubicRecord(const std::vector<double>& t, const std::vector<double>& a) : t_(t), a_(a) {}
  double TableAcceleration(double t_s) const override {
    if (!(t_s >= t_.front() && t_s <= t_.back())) return 0.0;
    const auto k = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t_s) - t_.begin());
    const std::size_t i = std::min(k, t_.size() - 1) - 1;
    const double h = t_[i + 1] - t_[i];
    const double u = (t_s - t_[i]) / h;
    const double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * a_[i] + (u3 - 2 * u2 + u) * h * Slope(i) + (-2 * u3 + 3 * u2) * a_[i + 1] +
           (u3 - u2) * h * Slope(i + 1);
  }
  double NextDiscontinuity(double t_s) const override {
    if (t_s < t_.front()) return t_.front();
    if (t_s < t_.back()) return t_.back();
    return std::numeric_limits<double>::infinity();
  }

 private:
  double Slope(std::size_t i) const {
    const std::size_t lo = i == 0 ? 0 : i - 1, hi = std::min(i + 1, t_.size() - 1);
    return (a_[hi] - a_[lo]) / (t_[hi] - t_[lo]);
  }
  const std::vector<double>& t_;  // non-owning: the record's
  const std::vector<double>& a_;
};

}  // namespace

FitResult FitTrajectory(const RockingRecord& record, const FitOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  FitResult out = StartFit(FitMethod::kTrajectory, record, options);
  const FreeRockingFeatures& f = out.features;
  out.forced = record.has_table() && MaxAbsTable(record) > kForcedTableAccel;

  // Initial state: at rest (a forced test) or a held release (free).
  const std::size_t head = std::min<std::size_t>(record.size(), std::max<std::size_t>(
      20, Range(record.time_s, record.time_s[0], record.time_s[0] + 0.05).second));
  bool at_rest = true;
  for (std::size_t k = 0; k < head; ++k) at_rest = at_rest && std::abs(record.theta[k]) < f.hysteresis_rad;
  const bool from_hold = !at_rest && f.release_time_s.has_value();
  if (!at_rest && !from_hold) {
    throw FitError(record.source + ": the trajectory method needs a record that starts at rest "
                   "(forced test) or holds the block before releasing it (free test); this one "
                   "starts moving at " + Num(record.time_s[0], 5) + " s");
  }
  if (at_rest && !out.forced) {
    throw FitError(record.source + ": the record starts at rest and has no table motion to "
                   "start the rocking (give the table acceleration for a forced test)");
  }

  // Start values.
  BlockParams start_params;
  std::string start_from;
  if (options.start) {
    start_params = *options.start;
    start_from = "given";
  } else if (!out.forced) {
    try {
      FitOptions o = options;
      o.on_progress = nullptr;
      start_params = FitImpacts(record, o).params;
      start_from = "impacts method";
    } catch (const FitError&) {
      if (!out.theory) throw;
    }
  }
  if (start_from.empty()) {
    if (!out.theory) {
      throw FitError(record.source + ": the trajectory method needs start values: give the "
                     "geometry (--rig or --width/--height)");
    }
    start_params = *out.theory;
    start_from = "geometry";
  }

  std::unique_ptr<Forcing> forcing;
  if (record.has_table()) {
    forcing = std::make_unique<SampledAcceleration>(record.table_time_s, record.table_accel_mps2);
  } else {
    forcing = std::make_unique<NoTableMotion>();
  }
  const std::size_t first = from_hold ? f.hold_start_index : 0;
  const double theta0 = from_hold ? f.first_sign * *f.r0_rad : 0.0;
  TrajectoryFunctor functor(record, first, *forcing, from_hold, theta0, options.rtol);
  Eigen::VectorXd x(from_hold ? 4 : 3);
  x(0) = start_params.alpha;
  x(1) = start_params.p;
  x(2) = start_params.mu;
  if (from_hold) x(3) = *f.release_time_s;
  // Whether and when a forced block uplifts hinges on alpha (|u_g''| >
  // g tan(alpha)), so the cost is rugged in alpha and LM can stop in a local
  // minimum. When the first fit does not get down to the noise (1.5 x the
  // estimated noise), it restarts from the best points of a coarse alpha scan
  // (+-15 % in 2.5 % steps, p and mu held) and keeps the lowest cost.
  std::vector<Eigen::VectorXd> starts{x};
  if (out.forced && !options.start) {
    std::vector<std::pair<double, double>> scan;  // (cost, alpha)
    Eigen::VectorXd trial = x;
    Eigen::VectorXd fv(functor.values());
    for (int i = -6; i <= 6; ++i) {
      if (i == 0) continue;
      trial(0) = x(0) * (1.0 + 0.025 * i);
      functor(trial, fv);
      scan.emplace_back(fv.squaredNorm(), trial(0));
    }
    std::sort(scan.begin(), scan.end());
    for (std::size_t i = 0; i < 3 && i < scan.size(); ++i) {
      trial(0) = scan[i].second;
      starts.push_back(trial);
    }
  }
  LmOutcome lm;
  bool have = false;
  int restarts = 0;
  int evaluations = 0;
  for (const Eigen::VectorXd& x_start : starts) {
    LmOutcome trial = RunLm(functor, x_start, 1e-10, 1e-8, 1e-10, options.max_evaluations, options, start);
    evaluations = *functor.count_;
    if (!have || (LmConverged(trial.status) && trial.residuals.squaredNorm() < lm.residuals.squaredNorm()) ||
        !LmConverged(lm.status)) {
      lm = std::move(trial);
      have = true;
    }
    const double rms = std::sqrt(lm.residuals.squaredNorm() / static_cast<double>(lm.residuals.size()));
    if (LmConverged(lm.status) && rms <= 1.5 * f.noise_rad) break;
    ++restarts;
  }
  lm.evaluations = evaluations;
  if (restarts > 0) {
    out.warnings.push_back("restarted " + std::to_string(std::min<int>(restarts, static_cast<int>(starts.size()) - 1)) +
                           " time(s) from an alpha scan (first fit above the noise level)");
  }
  if (!LmConverged(lm.status)) {
    throw FitError(record.source + ": the trajectory fit did not converge in " +
                   std::to_string(lm.evaluations) + " model runs (status " +
                   std::to_string(static_cast<int>(lm.status)) + ", start from the " + start_from + ")");
  }
  out.params = {lm.x(0), lm.x(1), lm.x(2)};
  try {
    out.params.Validate();
  } catch (const std::invalid_argument& e) {
    throw FitError(record.source + ": the trajectory fit left the physical range: " + e.what());
  }
  if (from_hold) out.release_time_s = lm.x(3);
  out.covariance = Covariance(lm);
  out.alpha_stderr = std::sqrt(out.covariance(0, 0));
  out.p_stderr = std::sqrt(out.covariance(1, 1));
  out.mu_stderr = std::sqrt(out.covariance(2, 2));
  out.alpha_p_correlation = out.covariance(0, 1) / (out.alpha_stderr * out.p_stderr);
  if (out.forced) {
    // The table record's sampling: the same run on the cubic through the
    // samples; the difference d is about the chord's error.
    const CubicRecord cubic(record.table_time_s, record.table_accel_mps2);
    const TrajectoryFunctor on_cubic(record, first, cubic, from_hold, theta0, options.rtol);
    Eigen::VectorXd fc(lm.residuals.size());
    on_cubic(lm.x, fc);
    const Eigen::VectorXd d = fc - lm.residuals;
    out.table_interpolation_rad = std::sqrt(d.squaredNorm() / static_cast<double>(d.size()));
    const Eigen::MatrixXd jtj = lm.jacobian.transpose() * lm.jacobian;
    const Eigen::VectorXd shift = -jtj.fullPivLu().solve(lm.jacobian.transpose() * d);
    out.table_interpolation_shift = {shift(0), shift(1), shift(2)};
    const double stat[3] = {out.alpha_stderr, out.p_stderr, out.mu_stderr};
    bool dominates = false;
    for (int i = 0; i < 3; ++i) dominates = dominates || std::abs(shift(i)) > stat[i];
    out.alpha_stderr = std::hypot(out.alpha_stderr, shift(0));
    out.p_stderr = std::hypot(out.p_stderr, shift(1));
    out.mu_stderr = std::hypot(out.mu_stderr, shift(2));
    if (dominates) {
      out.warnings.push_back(
          "the table record's sampling moves the fit more than its noise does: between samples the "
          "acceleration is a chord, which shifts alpha by " + Num(shift(0), 2) + " rad, p by " +
          Num(shift(1), 2) + " rad/s, mu by " + Num(shift(2), 2) + " (theta by " +
          Num(out.table_interpolation_rad, 2) + " rad rms); the standard errors include it; record "
          "the table acceleration faster for a sharper fit");
    }
  }
  out.mu_spread = kNaN;
  out.residuals = static_cast<int>(lm.residuals.size());
  out.dof = out.residuals - static_cast<int>(lm.x.size());
  out.rms_residual = std::sqrt(lm.residuals.squaredNorm() / out.residuals);
  out.iterations = lm.iterations;
  out.evaluations = lm.evaluations;
  SetNoiseVerdict(lm.residuals, std::vector<double>(static_cast<std::size_t>(lm.residuals.size()), f.noise_rad),
                  LmConverged(lm.status), out);
  out.warnings.push_back("start values from the " + start_from);
  AddVerdictWarnings(out, "skipped (the residuals are at the samples present)");
  if (out.band && (out.params.alpha < out.band->lo || out.params.alpha > out.band->hi)) {
    throw FitError(record.source + ": fitted alpha " + Num(out.params.alpha, 4) +
                   " rad is outside the admissible band [" + Num(out.band->lo, 4) + ", " +
                   Num(out.band->hi, 4) + "] rad (geometric alpha " + Num(out.band->geometric, 4) +
                   " rad, b +- " + Num(out.band->band_m, 3) +
                   " m): solution rejected (widen with --alpha-band-m)");
  }
  out.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rocklab::model
