#pragma once
/// @file
/// Affine-invariant ensemble sampler (Goodman and Weare 2010, the stretch
/// move with a = 2, the algorithm of emcee) and its convergence diagnostics
/// (docs/identification.md).
///
/// The walkers are split in two halves; each half moves with proposals drawn
/// from the other half, so the walkers of a half are independent of each
/// other and run in parallel (std::thread). Every walker draws from its own
/// random stream (seeded from the run's seed and the walker's index), so the
/// draws depend on the seed only, never on the number of threads.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/cancel.h"

namespace rocklab::model {

/// Log of an unnormalised density; -infinity outside its support. Called
/// from several threads at once: it must be thread-safe (no shared mutable
/// state).
using LogDensity = std::function<double(const Eigen::VectorXd&)>;
/// The same, given the run's cancel token to poll inside a long evaluation
/// (token.ThrowIfCancelled(), on whichever thread it runs): Ctrl-C then
/// stops the run within an evaluation, not after a whole step.
using CancellableLogDensity = std::function<double(const Eigen::VectorXd&, const CancelToken&)>;

/// A counter-based random stream: SplitMix64 of (seed, stream, counter),
/// reproducible on every platform (no std:: distribution).
class RandomStream {
 public:
  RandomStream(std::uint64_t seed, std::uint64_t stream);
  std::uint64_t NextU64();
  double Uniform();  ///< in [0, 1), 53 bits
  double Normal();   ///< standard normal (Box-Muller)
  /// Uniform integer in [0, n), n > 0 (floor of n times a uniform draw).
  std::uint64_t Below(std::uint64_t n);

 private:
  std::uint64_t state_;
};

struct EnsembleOptions {
  int walkers{32};      ///< even, >= 2 x dimension
  int steps{2000};      ///< steps per walker (after the start)
  std::uint64_t seed{1};
  double a{2.0};        ///< stretch scale, > 1
  int threads{0};       ///< 0: std::thread::hardware_concurrency()
  /// Called after every step with (step, steps) on the calling thread (may
  /// be empty). Must not throw.
  std::function<void(int, int)> on_step;
  /// Polled on the calling thread after every step, every 10 ms while it
  /// waits for the other threads, and by a CancellableLogDensity inside its
  /// evaluations (model/cancel.h): true stops the sampling with Cancelled.
  CancelHook cancelled;
  /// @throws std::invalid_argument naming the option.
  void Validate(int dimension) const;
};

/// The chain of a run: position of walker w after step s (s = 0 .. steps-1).
struct EnsembleRun {
  int walkers{};
  int steps{};
  int dimension{};
  /// Row s * walkers + w: walker w after step s.
  Eigen::MatrixXd chain;
  /// Log density of each row of `chain`.
  Eigen::VectorXd log_density;
  /// Accepted proposals per walker.
  std::vector<long> accepted;
  int threads{};  ///< threads used
  /// Position of walker w after step s.
  Eigen::VectorXd At(int step, int walker) const {
    return chain.row(static_cast<Eigen::Index>(step) * walkers + walker).transpose();
  }
};

/// Runs the stretch move from `start` (walkers x dimension, one row per
/// walker, every one with a finite log density).
/// @throws std::invalid_argument for bad options or a start outside the support.
EnsembleRun RunEnsemble(const LogDensity& log_density, const Eigen::MatrixXd& start,
                        const EnsembleOptions& options);
/// The same with a log density that polls the run's cancel token.
/// @throws also Cancelled when options.cancelled says stop.
EnsembleRun RunEnsembleCancellable(const CancellableLogDensity& log_density, const Eigen::MatrixXd& start,
                                   const EnsembleOptions& options);

/// Integrated autocorrelation time of a series of walkers (x[w][t]), in
/// steps: the normalised autocorrelation function averaged over the walkers,
/// tau(M) = 1 + 2 sum_{t=1}^{M} rho(t), with Sokal's automated window: the
/// smallest M >= c tau(M) (c = 5), as emcee does. NaN for fewer than 2 steps
/// or a constant series.
double IntegratedAutocorrTime(const std::vector<std::vector<double>>& walkers, double c = 5.0);

/// Split R-hat (Gelman et al., BDA3 eq. 11.4) over the walkers, each split in
/// halves: 2W chains of n/2 steps. NaN below 4 steps.
double SplitRhat(const std::vector<std::vector<double>>& walkers);

/// Convergence of a run, per parameter, over the kept steps (after burn-in).
struct EnsembleDiagnostics {
  int burn_in{};                   ///< steps dropped at the start
  int kept_steps{};                ///< steps per walker kept
  std::vector<double> tau;         ///< integrated autocorrelation time, steps
  std::vector<double> ess;         ///< effective sample size: walkers * kept_steps / tau
  std::vector<double> rhat;        ///< split R-hat
  double acceptance{};             ///< mean acceptance fraction over the walkers
  std::vector<double> walker_acceptance;
};

/// The rule every run is judged by (docs/identification.md).
struct ConvergenceRule {
  double max_rhat{1.05};       ///< split R-hat of every parameter at most this
  double min_ess{400.0};       ///< effective sample size of every parameter at least this
  double min_steps_per_tau{20.0};  ///< kept steps at least this many times the largest tau
  double min_acceptance{0.1};  ///< mean acceptance fraction at least this
};

/// Diagnostics over the steps after the first `burn_in`.
/// @throws std::invalid_argument when fewer than 4 steps are kept.
EnsembleDiagnostics Diagnose(const EnsembleRun& run, int burn_in);

/// Empty when the rule holds; else one line per failed condition, naming the
/// parameter (`names`, one per dimension) and the figures.
std::vector<std::string> ConvergenceProblems(const EnsembleDiagnostics& d, const ConvergenceRule& rule,
                                             const std::vector<std::string>& names);

}  // namespace rocklab::model
