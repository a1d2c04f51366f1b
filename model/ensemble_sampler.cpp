// The stretch-move ensemble sampler and its diagnostics
// (model/ensemble_sampler.h; the derivations in docs/identification.md).
#include "model/ensemble_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>
#include "common/units.h"

namespace rocklab::model {
namespace {

using common::kNaN;
constexpr double kTwoPi = 6.283185307179586476925286766559;

std::uint64_t SplitMix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::string Fmt(double v, int digits = 3) {
  std::ostringstream o;
  o.precision(digits);
  o << v;
  return o.str();
}

// The stretch move for walkers [first, first + n) of `pos` (every `stride`-th
// from `offset`, the share of one thread), partners from the other half.
struct HalfMove {
  const CancellableLogDensity* log_density;
  const CancelToken* token;
  Eigen::MatrixXd* pos;
  Eigen::VectorXd* lp;
  std::vector<RandomStream>* streams;
  std::vector<long>* accepted;
  int first;      // first walker of the moving half
  int partners;   // first walker of the other half
  int half;       // walkers per half
  double a;
  void Run(int offset, int stride) const {
    const auto dim = pos->cols();
    Eigen::VectorXd y(dim);
    for (int i = offset; i < half; i += stride) {
      const int k = first + i;
      RandomStream& rng = (*streams)[static_cast<std::size_t>(k)];
      const int j = partners + static_cast<int>(rng.Below(static_cast<std::uint64_t>(half)));
      // z ~ g(z) proportional to 1/sqrt(z) on [1/a, a]: z = ((a - 1) u + 1)^2 / a.
      const double u = rng.Uniform();
      const double z = ((a - 1.0) * u + 1.0) * ((a - 1.0) * u + 1.0) / a;
      const double log_u = std::log(1.0 - rng.Uniform());  // in (-inf, 0]
      y = pos->row(j).transpose() + z * (pos->row(k).transpose() - pos->row(j).transpose());
      const double lp_y = (*log_density)(y, *token);
      const double log_q = static_cast<double>(dim - 1) * std::log(z) + lp_y - (*lp)(k);
      if (std::isfinite(lp_y) && log_u < log_q) {
        pos->row(k) = y.transpose();
        (*lp)(k) = lp_y;
        ++(*accepted)[static_cast<std::size_t>(k)];
      }
    }
  }
};

}  // namespace

RandomStream::RandomStream(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t s = seed;
  const std::uint64_t a = SplitMix64(s);
  std::uint64_t t = stream ^ 0xD1B54A32D192ED03ULL;
  state_ = a ^ SplitMix64(t);
}

std::uint64_t RandomStream::NextU64() { return SplitMix64(state_); }

double RandomStream::Uniform() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }

double RandomStream::Normal() {
  const double u1 = 1.0 - Uniform();  // (0, 1]
  const double u2 = Uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
}

std::uint64_t RandomStream::Below(std::uint64_t n) {
  const auto k = static_cast<std::uint64_t>(Uniform() * static_cast<double>(n));
  return std::min(k, n - 1);
}

void EnsembleOptions::Validate(int dimension) const {
  if (walkers < 2 * dimension || walkers % 2 != 0) {
    throw std::invalid_argument("walkers must be even and at least twice the number of parameters (" +
                                std::to_string(2 * dimension) + "), got " + std::to_string(walkers));
  }
  if (steps < 4) throw std::invalid_argument("steps must be >= 4, got " + std::to_string(steps));
  if (!(a > 1.0)) throw std::invalid_argument("the stretch scale a must be > 1, got " + Fmt(a));
  if (threads < 0) throw std::invalid_argument("threads must be >= 0, got " + std::to_string(threads));
}

EnsembleRun RunEnsemble(const LogDensity& log_density, const Eigen::MatrixXd& start,
                        const EnsembleOptions& options) {
  return RunEnsembleCancellable([&log_density](const Eigen::VectorXd& x, const CancelToken&) { return log_density(x); },
                                start, options);
}

EnsembleRun RunEnsembleCancellable(const CancellableLogDensity& log_density, const Eigen::MatrixXd& start,
                                   const EnsembleOptions& options) {
  const CancelToken token(options.cancelled);
  const int dim = static_cast<int>(start.cols());
  options.Validate(dim);
  if (start.rows() != options.walkers) {
    throw std::invalid_argument("start has " + std::to_string(start.rows()) + " rows for " +
                                std::to_string(options.walkers) + " walkers");
  }
  const int w = options.walkers;
  const int half = w / 2;
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, half);

  Eigen::MatrixXd pos = start;
  Eigen::VectorXd lp(w);
  for (int k = 0; k < w; ++k) {
    lp(k) = log_density(pos.row(k).transpose(), token);
    if (!std::isfinite(lp(k))) {
      throw std::invalid_argument("walker " + std::to_string(k) + " starts where the log density is not finite");
    }
  }
  std::vector<RandomStream> streams;
  streams.reserve(static_cast<std::size_t>(w));
  for (int k = 0; k < w; ++k) streams.emplace_back(options.seed, static_cast<std::uint64_t>(k));

  EnsembleRun run;
  run.walkers = w;
  run.steps = options.steps;
  run.dimension = dim;
  run.threads = threads;
  run.chain.resize(static_cast<Eigen::Index>(options.steps) * w, dim);
  run.log_density.resize(static_cast<Eigen::Index>(options.steps) * w);
  run.accepted.assign(static_cast<std::size_t>(w), 0);

  for (int s = 0; s < options.steps; ++s) {
    for (int h = 0; h < 2; ++h) {
      const HalfMove move{&log_density, &token, &pos, &lp, &streams, &run.accepted,
                          h * half, (1 - h) * half, half, options.a};
      common::RunOnThreads(threads, token, [&move, threads](int t) { move.Run(t, threads); });
      token.ThrowIfCancelled();  // seen by a worker only (the work may have ended at once)
    }
    run.chain.middleRows(static_cast<Eigen::Index>(s) * w, w) = pos;
    run.log_density.segment(static_cast<Eigen::Index>(s) * w, w) = lp;
    if (options.on_step) options.on_step(s + 1, options.steps);
    token.ThrowIfCancelled();
  }
  return run;
}

double IntegratedAutocorrTime(const std::vector<std::vector<double>>& walkers, double c) {
  if (walkers.empty() || walkers[0].size() < 2) return kNaN;
  const std::size_t n = walkers[0].size();
  // Centred series and their variances (sum of squares); constant walkers
  // (a walker that never moved) carry no information on the correlation.
  std::vector<std::vector<double>> x;
  std::vector<double> c0;
  for (const std::vector<double>& wk : walkers) {
    if (wk.size() != n) throw std::invalid_argument("walkers of different lengths");
    double mean = 0.0;
    for (double v : wk) mean += v;
    mean /= static_cast<double>(n);
    std::vector<double> d(n);
    double ss = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      d[i] = wk[i] - mean;
      ss += d[i] * d[i];
    }
    if (ss > 0.0) {
      x.push_back(std::move(d));
      c0.push_back(ss);
    }
  }
  if (x.empty()) return kNaN;
  // rho(t) = mean over walkers of sum_i d_i d_{i+t} / sum_i d_i^2 (the
  // biased estimator, as emcee's FFT); tau(M) = 1 + 2 sum_{t<=M} rho(t),
  // stopped at the first M >= c tau(M).
  double tau = 1.0;
  for (std::size_t t = 1; t < n; ++t) {
    double rho = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      const std::vector<double>& d = x[k];
      double s = 0.0;
      for (std::size_t i = 0; i + t < n; ++i) s += d[i] * d[i + t];
      rho += s / c0[k];
    }
    tau += 2.0 * rho / static_cast<double>(x.size());
    if (static_cast<double>(t) >= c * tau) return tau;
  }
  return tau;  // the window never closed: a lower bound (the run is too short)
}

double SplitRhat(const std::vector<std::vector<double>>& walkers) {
  if (walkers.empty() || walkers[0].size() < 4) return kNaN;
  const std::size_t n = walkers[0].size() / 2;
  const std::size_t skip = walkers[0].size() - 2 * n;  // odd length: drop the first sample
  std::vector<double> means;
  std::vector<double> vars;
  for (const std::vector<double>& wk : walkers) {
    for (int part = 0; part < 2; ++part) {
      const std::size_t b = skip + part * n;
      double m = 0.0;
      for (std::size_t i = 0; i < n; ++i) m += wk[b + i];
      m /= static_cast<double>(n);
      double v = 0.0;
      for (std::size_t i = 0; i < n; ++i) v += (wk[b + i] - m) * (wk[b + i] - m);
      means.push_back(m);
      vars.push_back(v / static_cast<double>(n - 1));
    }
  }
  const double chains = static_cast<double>(means.size());
  double grand = 0.0;
  for (double m : means) grand += m;
  grand /= chains;
  double between = 0.0;
  for (double m : means) between += (m - grand) * (m - grand);
  between *= static_cast<double>(n) / (chains - 1.0);
  double within = 0.0;
  for (double v : vars) within += v;
  within /= chains;
  if (!(within > 0.0)) return between > 0.0 ? std::numeric_limits<double>::infinity() : kNaN;
  const double nn = static_cast<double>(n);
  return std::sqrt(((nn - 1.0) / nn * within + between / nn) / within);
}

EnsembleDiagnostics Diagnose(const EnsembleRun& run, int burn_in) {
  EnsembleDiagnostics d;
  d.burn_in = burn_in;
  d.kept_steps = run.steps - burn_in;
  if (burn_in < 0 || d.kept_steps < 4) {
    throw std::invalid_argument("diagnostics need at least 4 steps after a burn-in of " + std::to_string(burn_in));
  }
  for (int p = 0; p < run.dimension; ++p) {
    std::vector<std::vector<double>> series(static_cast<std::size_t>(run.walkers),
                                            std::vector<double>(static_cast<std::size_t>(d.kept_steps)));
    for (int s = burn_in; s < run.steps; ++s) {
      for (int k = 0; k < run.walkers; ++k) {
        series[static_cast<std::size_t>(k)][static_cast<std::size_t>(s - burn_in)] =
            run.chain(static_cast<Eigen::Index>(s) * run.walkers + k, p);
      }
    }
    const double tau = IntegratedAutocorrTime(series);
    d.tau.push_back(tau);
    d.ess.push_back(static_cast<double>(run.walkers) * d.kept_steps / tau);
    d.rhat.push_back(SplitRhat(series));
  }
  double sum = 0.0;
  for (long a : run.accepted) {
    d.walker_acceptance.push_back(static_cast<double>(a) / run.steps);
    sum += d.walker_acceptance.back();
  }
  d.acceptance = sum / run.walkers;
  return d;
}

std::vector<std::string> ConvergenceProblems(const EnsembleDiagnostics& d, const ConvergenceRule& rule,
                                             const std::vector<std::string>& names) {
  std::vector<std::string> out;
  double max_tau = 0.0;
  for (std::size_t p = 0; p < d.tau.size(); ++p) {
    const std::string& name = p < names.size() ? names[p] : "#" + std::to_string(p);
    if (!(d.rhat[p] <= rule.max_rhat)) {
      out.push_back("split R-hat of " + name + " is " + Fmt(d.rhat[p], 4) + " (above " + Fmt(rule.max_rhat) + ")");
    }
    if (!(d.ess[p] >= rule.min_ess)) {
      out.push_back("effective sample size of " + name + " is " + Fmt(d.ess[p], 4) + " (below " +
                    Fmt(rule.min_ess, 4) + ")");
    }
    max_tau = std::isfinite(d.tau[p]) ? std::max(max_tau, d.tau[p]) : std::numeric_limits<double>::infinity();
  }
  if (!(d.kept_steps >= rule.min_steps_per_tau * max_tau)) {
    out.push_back(std::to_string(d.kept_steps) + " steps kept after burn-in are " +
                  Fmt(d.kept_steps / max_tau, 3) + " autocorrelation times (tau " + Fmt(max_tau, 4) +
                  " steps); at least " + Fmt(rule.min_steps_per_tau) + " are needed");
  }
  if (!(d.acceptance >= rule.min_acceptance)) {
    out.push_back("acceptance fraction " + Fmt(d.acceptance, 3) + " (below " + Fmt(rule.min_acceptance) + ")");
  }
  return out;
}

}  // namespace rocklab::model
