#pragma once
/// @file
/// A posterior for the block's parameters: p(alpha, p, mu [, l], sigma,
/// t_offset | record), sampled with the ensemble sampler
/// (model/ensemble_sampler.h). Likelihoods (docs/identification.md):
///
/// - impacts (free rocking): the impact times and peaks of
///   ExtractFreeRocking against the closed-form free rocking of Housner's
///   model from the release amplitude r_0 (quarter times, eq. 12 corrected,
///   and the peak after each impact by energy); Gaussian errors whose
///   standard deviations are the features' own standard errors scaled by
///   sigma / (the noise they were computed with). A record that starts at
///   a peak (no r_0) starts the chain from the peak after the first impact.
/// - trajectory: every theta sample against a model run (Housner or the
///   complex formulation, free from the held release or forced by the
///   record's table acceleration), white Gaussian noise of standard
///   deviation sigma.
///
/// Priors (uniform unless said; PosteriorPriors, the rig's [posterior]
/// section): alpha on the admissible band of the geometry, p on
/// geometric p x [1 - p_range, 1 + p_range], mu on (mu_min, mu_max], log10 l
/// on [log10_l_min, log10_l_max] (complex model), sigma log-uniform on
/// [noise / 10, 10 noise] (noise from the record, EstimateThetaNoise), the
/// time offset on [-t_offset_s, t_offset_s]. The time offset shifts the
/// release (free) or the table record against theta (forced). Optionally
/// (impacts likelihood, PosteriorPriors::per_impact_mu) a restitution per
/// impact, mu_n ~ N(mu, sigma_mu^2), with sigma_mu sampled.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/ensemble_sampler.h"
#include "model/fit.h"
#include "model/rocking_model.h"

namespace rocklab::model {

/// The stated priors (docs/identification.md; rig file [posterior]).
struct PosteriorPriors {
  double alpha_band_m{0.01};  ///< alpha uniform on the band of b -+ this, m
  double p_range{0.3};        ///< p uniform on geometric p x [1 -+ p_range], 1; in (0, 1)
  double mu_min{0.0};         ///< mu uniform on (mu_min, mu_max], 1
  double mu_max{1.0};
  double log10_l_min{-14.0};  ///< complex model: log10 l uniform on [min, max]
  double log10_l_max{-8.0};
  double t_offset_s{0.05};    ///< time offset uniform on [-t_offset_s, t_offset_s], s
  /// Impacts likelihood: each impact n has its own restitution
  /// mu_n ~ N(mu_bar, sigma_mu^2) (mu is then mu_bar), marginalised to
  /// first order in mu_n - mu_bar (docs/identification.md); sigma_mu is
  /// sampled, uniform on (0, sigma_mu_max].
  bool per_impact_mu{false};
  double sigma_mu_max{0.1};
  /// @throws std::invalid_argument naming the key.
  void Validate() const;
};

struct PosteriorOptions {
  FitMethod method{FitMethod::kImpacts};
  ModelKind model{ModelKind::kHousner};  ///< trajectory likelihood only
  /// Geometry (required: the priors come from it) and the features' options.
  FitOptions fit;
  PosteriorPriors priors;
  /// The trajectory likelihood's model run: relative tolerance and
  /// integrator (docs/performance.md: what a looser one costs).
  double rtol{1e-6};
  Integrator integrator{Integrator::kAdams};
  /// Trajectory likelihood, Housner's model: the model is output at every
  /// this many samples and theta between comes from cubic Hermite
  /// interpolation split at its events (docs/identification.md); 1: every
  /// sample. The complex model is output at every sample.
  int output_stride{10};
  /// Trajectory likelihood, Housner's model in free rocking (no table):
  /// SampleFreeHousner (model/free_rocking.h: fixed-step RK4 output at every
  /// sample, ~4 times cheaper than the CVODE model with the stride, and
  /// closer to rtol 1e-10) instead of the CVODE model; rtol, integrator and
  /// output_stride then do not apply (docs/performance.md, "Posterior").
  bool free_rk4{true};
  /// Points drawn from the prior for the walkers' start (0: the point fit's).
  int start_scan{256};
  EnsembleOptions sampler;
  /// Steps dropped before the diagnostics and the draws; -1: half the steps.
  int burn_in{-1};
  ConvergenceRule rule;
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// The log posterior of one record: thread-safe, cheap to copy (the record
/// and features are shared).
class PosteriorProblem {
 public:
  /// `point`: the point fit of the same record and method when the caller
  /// has one (else it is run here; its failure leaves the walkers to start
  /// at the geometry). `options.fit.cancelled` is polled while it is built
  /// (the feature scan, the point fit, the start's scan) and not kept.
  /// @throws Cancelled when options.fit.cancelled says stop; FitError when the record cannot give a posterior (never rocks,
  ///         overturns, too few impacts, a start the likelihood cannot
  ///         use), std::invalid_argument for bad options (no geometry).
  PosteriorProblem(const RockingRecord& record, const PosteriorOptions& options, const FitResult* point = nullptr);

  /// Names of the sampled parameters in order: alpha, p, mu[, l]
  /// [, sigma_mu], sigma, t_offset (l is sampled as log10 l; see
  /// ToReported; with per-impact restitution mu is its mean mu_bar).
  const std::vector<std::string>& names() const;
  int dimension() const;
  /// log prior + log likelihood at x (sampled coordinates), -infinity
  /// outside the prior's support or where the model fails.
  double LogPosterior(const Eigen::VectorXd& x) const;
  /// The same, polling `token` inside the model run (every 256 samples).
  /// @throws Cancelled when it says stop.
  double LogPosterior(const Eigen::VectorXd& x, const CancelToken& token) const;
  double LogPrior(const Eigen::VectorXd& x) const;
  /// The sampled coordinates in the reported units (l = 10^x(3)).
  Eigen::VectorXd ToReported(const Eigen::VectorXd& x) const;
  /// A start point inside the support: the highest log posterior of the
  /// point fit (else the geometry's parameters) and start_scan points drawn from
  /// the prior of alpha, p, mu (, log10 l), with sigma the estimated noise
  /// and no offset (the point fit's release offset).
  Eigen::VectorXd Start() const;
  /// The start came from the prior scan, not the point fit.
  bool start_from_scan() const;
  /// Per coordinate, a scale for the walkers' initial ball.
  Eigen::VectorXd StartScale() const;
  /// Lower and upper ends of the prior's support per coordinate.
  const Eigen::VectorXd& lower() const;
  const Eigen::VectorXd& upper() const;
  const FitResult& point() const;  ///< the point fit (or the opening of one)
  bool point_fitted() const;       ///< the point fit succeeded
  std::string point_error() const; ///< why it did not
  bool forced() const;
  int data_points() const;         ///< impacts + peaks, or theta samples

  struct Impl;

 private:
  std::shared_ptr<const Impl> impl_;
};

/// Per parameter (reported units).
struct ParameterSummary {
  std::string name;
  double median{};
  double ci68_lo{}, ci68_hi{};  ///< 16th and 84th percentiles
  double ci95_lo{}, ci95_hi{};  ///< 2.5th and 97.5th percentiles
  double mean{};
  double sd{};
  double rhat{};
  double ess{};
  double tau{};  ///< steps
};

struct PosteriorResult {
  std::vector<std::string> names;  ///< reported parameter names
  std::string method;              ///< "impacts" / "trajectory"
  std::string model;               ///< "housner" / "complex"
  /// Kept draws (after burn-in), reported units, one row per draw (step
  /// major, walker minor), one column per name.
  Eigen::MatrixXd draws;
  Eigen::VectorXd log_posterior;   ///< of each draw
  std::vector<ParameterSummary> summary;
  Eigen::MatrixXd correlation;     ///< of the reported parameters, in `names` order
  EnsembleDiagnostics diagnostics;
  int walkers{};
  int steps{};
  std::uint64_t seed{};
  int threads{};
  double runtime_s{};
  /// Conditions of the convergence rule that failed (empty: converged).
  std::vector<std::string> problems;
  bool converged() const { return problems.empty(); }
  bool point_fitted{};
  std::string start_from;          ///< "point fit" / "prior scan" / "geometry"
  std::vector<std::string> warnings;
};

/// Builds the problem, starts the walkers in a ball about Start() and runs
/// the sampler.
/// @throws as PosteriorProblem, std::invalid_argument for bad options.
PosteriorResult SamplePosterior(const RockingRecord& record, const PosteriorOptions& options);
/// The same on a built problem.
PosteriorResult SamplePosterior(const PosteriorProblem& problem, const PosteriorOptions& options);

/// Percentile q in [0, 1] of v (linear between order statistics, as numpy's
/// default).
double Quantile(std::vector<double> v, double q);

/// The `posterior` object of `rocklab fit --json` (docs/identification.md)
/// as JSON text.
std::string PosteriorJson(const PosteriorResult& r);

}  // namespace rocklab::model
