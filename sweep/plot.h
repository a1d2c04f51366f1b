#pragma once
/// @file
/// `rocklab sweep-plot`: a sweep's results as figures (gnuplot, through
/// report::RunGnuplot) and fragility fits.
///
/// A block is a (model, alpha, p, mu) of the results, compared as written.
/// Overturned cases count as peak theta/alpha = 1 in spectra and medians
/// (the block left its base: the spectrum's ceiling).

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "report/report_figure.h"
#include "sweep/fragility.h"

namespace rocklab::sweep {

/// One row of a results file, the columns the figures use.
struct ResultRow {
  std::string record, model;
  std::string alpha_text, p_text, mu_text;  ///< as written (they name the block)
  std::string block{"-"};  ///< the `block` column when there is one: "-", "WxH" or a polygon file's name
  double scale{}, pga_g{}, alpha{}, p{}, mu{};
  double peak_theta_over_alpha{};
  bool overturned{};
  /// An assembly's sweep (`first_overturned_body` column): the body that
  /// overturned first; "" when none did or the results have no such column.
  std::string first_overturned_body;
};

/// The values of a row sweep-plot checks, whatever file they come from.
struct RowValues {
  double scale{}, pga_g{}, alpha{}, p{}, mu{}, peak_theta_over_alpha{};
  double overturned{};  ///< 0 or 1
};

/// What sweep-plot refuses in a row, "" when it takes it: scale, pga_g,
/// alpha, p, mu or peak_theta_over_alpha not a finite number, overturned
/// not 0 or 1, pga_g or alpha not > 0. The one check of sweep-plot's
/// readers (CSV and HDF5) and of `sweep --merge`, so a merge never writes
/// a row that sweep-plot would refuse.
std::string RowProblem(const RowValues& v);

/// Reads a sweep's results: the HDF5 file of `sweep --out FILE.h5` (by its
/// signature, whatever the name: ReadResultsH5), else a CSV by its header's
/// column names (extra columns allowed; `#` lines before the header, the
/// sweep's definition, skipped).
/// @throws std::runtime_error "FILE:LINE: ..." for a missing column, a
///   field that is not a number, or a short row.
std::vector<ResultRow> ReadResults(const std::string& path);

/// Fewer overturned (or fewer safe) cases than this and a fitted curve
/// carries a caveat: with under about 10 events per fitted parameter a
/// binary regression's estimates are biased and their intervals unreliable
/// (Peduzzi et al. 1996, J Clin Epidemiol 49, the "10 events per
/// variable" rule, for logistic regression; the probit behaves alike).
inline constexpr std::size_t kFewOutcomes = 10;

/// The fragility of one block.
struct BlockFragility {
  std::string model, alpha, p, mu;  ///< as written
  std::size_t rows{}, overturned{};
  FragilityFit fit;
  double pga_min_g{}, pga_max_g{};  ///< the PGAs tried, g
  /// kFitted: the 95 % profile-likelihood band (LikelihoodBand) at 200
  /// PGAs from 0 to 1.1 x pga_max_g and the median's interval.
  FragilityBand band;
  /// kFitted: what makes the fit weak, "" when nothing does: the median
  /// outside [pga_min_g, pga_max_g] (extrapolated), fewer than
  /// kFewOutcomes overturned or safe cases, an interval the likelihood
  /// leaves open or that reaches beyond 10 x pga_max_g (or below
  /// pga_min_g / 10). Printed by sweep-plot, in the figure and in fragility.csv.
  std::string caveat;
  /// An assembly's sweep: how many cases each body overturned first, in
  /// the order the bodies first appear; empty for a sweep of blocks.
  std::vector<std::pair<std::string, std::size_t>> first_overturned;
};

/// Fits every block's fragility against PGA in g (rows grouped by block, in
/// their first appearance's order).
std::vector<BlockFragility> FitFragilities(const std::vector<ResultRow>& rows);

struct PlotOptions {
  std::string out_dir{"."};
  report::FigureFormat format{report::FigureFormat::kSvg};
  std::string gnuplot{"gnuplot"};
  std::size_t max_figures_per_kind{24};  ///< beyond this, a kind's figures are skipped (and counted)
  /// What made the figures (common::ProvenanceFields), written into each.
  std::vector<std::pair<std::string, std::string>> provenance;
};

/// What MakeFigures wrote.
struct PlotReport {
  std::vector<std::string> files;
  std::size_t skipped{};  ///< figures not drawn because of max_figures_per_kind
};

/// Draws the rocking spectra against p (per model, alpha, mu and scale, when
/// there are 2 or more p) and against PGA / (g tan alpha) (per block, when
/// there are 2 or more scales), per record with their median; the
/// overturning map (per model: p against PGA / (g tan alpha), coloured by
/// the share of records overturned); the fragility curves (per block, the
/// fraction overturned at each PGA and the fitted lognormal). Writes
/// fragility.csv beside them.
/// @throws report::FigureError from gnuplot; std::runtime_error when the
///   folder cannot be written.
PlotReport MakeFigures(const std::vector<ResultRow>& rows, const std::vector<BlockFragility>& fragilities,
                       const PlotOptions& options);

}  // namespace rocklab::sweep
