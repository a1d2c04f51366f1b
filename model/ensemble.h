#pragma once
/// @file
/// An ensemble of posterior draws run beside the point variants: the draws
/// read from a posterior samples CSV (`rocklab fit --posterior --samples`),
/// K of them picked deterministically, and the band the model node publishes
/// (quantiles of theta over the members; docs/models.md, "Posterior
/// predictive band").

#include <cstddef>
#include <string>
#include <vector>

#include "model/block.h"
#include "model/rocking_model.h"

namespace rocklab::model {

/// One posterior draw: the block's parameters, when the file has an `l`
/// column the complex formulation's l (NaN when it has none), and when it
/// has a `sigma` column the measurement noise's standard deviation.
struct PosteriorDraw {
  BlockParams params;  ///< alpha (rad), p (rad/s), mu (1)
  double l{};          ///< 1; NaN: the file has no `l` column
  double sigma{};      ///< rad, > 0; 0: the file has no `sigma` column
  int line{};          ///< line of the file it came from (1: the header)
};

/// Reads a posterior samples CSV: a header row naming the columns, at least
/// `alpha` (rad), `p` (rad/s) and `mu` (1), optionally `l` (1) and `sigma`
/// (rad, the measurement noise); every other column (`log_posterior`,
/// `t_offset`, ...) is read past. Blank lines
/// and lines starting with '#' are skipped.
/// @throws std::invalid_argument naming the file, line and column of a
///         missing column, a short row, a field that is not a finite number
///         or a draw whose parameters are invalid; and a file with no draw.
std::vector<PosteriorDraw> ReadPosteriorSamples(const std::string& path);

/// The draws' row indices an ensemble of `k` takes from `n` rows: evenly
/// spaced, floor(i n / k) for i = 0 .. k-1 (the first row always; with k >=
/// n every row once). Deterministic: the same file gives the same ensemble.
/// @throws std::invalid_argument for k < 1 or n < 1.
std::vector<std::size_t> PickDraws(std::size_t n, int k);

/// The ensemble the model node runs (RL_BAND_<name>).
struct EnsembleSpec {
  std::string name;                 ///< channel suffix: RL_BAND_<name>; [A-Za-z0-9_]+
  ModelKind kind{ModelKind::kComplex};
  std::vector<PosteriorDraw> draws; ///< the members' parameters (those picked)
  ModelOptions options;             ///< a draw's l, when given, replaces options.l
  std::string source;               ///< the samples file
  /// @throws std::invalid_argument naming what is wrong.
  void Validate() const;
};

/// Reads `path`, picks `k` draws (PickDraws) and names the ensemble.
/// @throws std::invalid_argument as ReadPosteriorSamples, or for a bad name.
EnsembleSpec MakeEnsemble(const std::string& name, ModelKind kind, const std::string& path, int k,
                          const ModelOptions& options);

/// Quantile `q` in [0, 1] of `sorted` (ascending, non-empty) by linear
/// interpolation between order statistics (Hyndman and Fan's type 7, numpy's
/// default): h = (n - 1) q, x[floor h] + (h - floor h) (x[floor h + 1] - x[floor h]).
double SortedQuantile(const std::vector<double>& sorted, double q);

/// The band's quantiles of one sample, rad.
struct BandQuantiles {
  double lo95{}, lo68{}, median{}, hi68{}, hi95{};
};
/// Sorts `values` in place and returns the 2.5, 16, 50, 84 and 97.5 %
/// quantiles (SortedQuantile); all NaN when `values` is empty.
BandQuantiles ComputeBand(std::vector<double>& values);

/// The same quantiles of a measurement predicted by the members: the
/// mixture (1/n) sum_k N(values[k], sigmas[k]^2), each quantile x solving
/// (1/n) sum_k Phi((x - values[k]) / sigmas[k]) = q to 1e-12 rad (Newton's
/// steps inside a bisection bracket). Every sigma must be > 0; with all
/// sigmas 0 use ComputeBand.
/// Precondition: values.size() == sigmas.size().
BandQuantiles ComputeNoisyBand(const std::vector<double>& values, const std::vector<double>& sigmas);

}  // namespace rocklab::model
