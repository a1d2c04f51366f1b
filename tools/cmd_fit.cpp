// rocklab fit: block parameters (alpha, p, mu) from a recorded test, by the
// paper's impacts method (free rocking) or a least-squares fit of the whole
// trajectory (free or forced).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <limits>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/progress.h"
#include "common/provenance.h"
#include "common/text.h"
#include "daq/rig_config.h"
#include "model/fit.h"
#include "model/model_registry.h"
#include "model/posterior.h"
#include "model/test_record.h"
#include "tools/cli.h"
#include "tools/formats.h"
#include "tools/posterior_output.h"

namespace rocklab::tools {
namespace {

struct FitCliOptions {
  std::string input;
  std::string rig;
  double width_m{};
  double height_m{};
  double chamfer_m{};
  std::string accel_csv;
  double start_s{0.0};                                 ///< window start, s from the record's first sample
  double end_s{std::numeric_limits<double>::infinity()};  ///< window end, s from it (infinity: to the end)
  std::string method{"impacts"};
  std::string quarter_time{"exact"};
  double alpha_band_m{0.01};
  int min_impacts{4};
  double rtol{model::FitOptions{}.rtol};
  double noise_rad{0.0};
  double significance{model::kDefaultSignificance};
  int starts{-1};
  std::string table{"spline"};  // --table: how a forced record's table samples are read between them
  bool json{};
  bool quiet{};
  std::string out_json;
  // --posterior (docs/identification.md)
  bool posterior{};
  std::uint64_t seed{1};
  int walkers{32};
  int steps{5000};
  int burn_in{-1};
  int threads{0};
  std::string model{"housner"};
  double posterior_rtol{model::PosteriorOptions{}.rtol};
  std::string integrator{"adams"};
  std::string samples;
  std::string plot;
  bool allow_unconverged{};
  bool per_impact_mu{};  // --per-impact-mu (or the rig's posterior.sigma_mu_max)
};

// Exit code of a fit whose point fit is not converged or whose posterior
// fails its convergence rule (without --allow-unconverged): its outputs are
// written, the verdict is not. The work failed, so 1, as every command's
// failure (docs/commands.md).
constexpr int kUnconvergedExit = 1;

void PrintPosterior(std::FILE* out, const model::PosteriorResult& p) {
  std::fprintf(out, "\nposterior (%s, %s model): %d walkers x %d steps, burn-in %d, %lld draws, seed %llu, %d threads, %.1f s\n",
              p.method.c_str(), p.model.c_str(), p.walkers, p.steps, p.diagnostics.burn_in,
              static_cast<long long>(p.draws.rows()), static_cast<unsigned long long>(p.seed), p.threads, p.runtime_s);
  std::fprintf(out, "%-9s %12s %25s %25s %11s %7s %7s %7s\n", "", "median", "68 % interval", "95 % interval", "sd", "R-hat",
              "ESS", "tau");
  for (const model::ParameterSummary& s : p.summary) {
    std::fprintf(out, "%-9s %12.6g [%11.6g, %11.6g] [%11.6g, %11.6g] %11.4g %7.4f %7.0f %7.1f\n", s.name.c_str(), s.median,
                s.ci68_lo, s.ci68_hi, s.ci95_lo, s.ci95_hi, s.sd, s.rhat, s.ess, s.tau);
  }
  std::fprintf(out, "correlation (%s):\n", [&p] {
    std::string order;
    for (const std::string& n : p.names) order += (order.empty() ? "" : ", ") + n;
    return order;
  }().c_str());
  for (Eigen::Index i = 0; i < p.correlation.rows(); ++i) {
    std::fprintf(out, "  %-9s", p.names[static_cast<std::size_t>(i)].c_str());
    for (Eigen::Index j = 0; j < p.correlation.cols(); ++j) std::fprintf(out, " %+6.3f", p.correlation(i, j));
    std::fprintf(out, "\n");
  }
  std::fprintf(out, "acceptance fraction %.3f; %s\n", p.diagnostics.acceptance,
              p.converged() ? "converged (split R-hat, ESS, steps per tau, acceptance)" : "NOT converged:");
  for (const std::string& problem : p.problems) std::fprintf(out, "  %s\n", problem.c_str());
  for (const std::string& w : p.warnings) std::fprintf(out, "note: %s\n", w.c_str());
}

nlohmann::json Optional(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
nlohmann::json Optional(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

nlohmann::json ResultJson(const FitCliOptions& o, const model::FitResult& r) {
  nlohmann::json impacts = nlohmann::json::array();
  for (const model::ImpactRow& row : r.impacts) {
    impacts.push_back({{"n", row.n},
                       {"time", Optional(row.time_s)},
                       {"peak", Optional(row.peak_rad)},
                       {"mu_n", Optional(row.mu_n)},
                       {"tau", Optional(row.tau_s)},
                       {"residual", Optional(row.residual_s)},
                       {"residual_noise", Optional(row.noise_s)}});
  }
  nlohmann::json j = {
      {"input", o.input},
      {"method", model::ToString(r.method)},
      {"quarter_time", r.method == model::FitMethod::kImpacts ? nlohmann::json(model::ToString(r.quarter_time))
                                                             : nlohmann::json(nullptr)},
      {"alpha", r.params.alpha},
      {"p", r.params.p},
      {"mu", r.params.mu},
      {"mu_spread", Optional(r.mu_spread)},
      {"alpha_stderr", Optional(r.alpha_stderr)},
      {"p_stderr", Optional(r.p_stderr)},
      {"mu_stderr", Optional(r.mu_stderr)},
      {"alpha_p_correlation", Optional(r.alpha_p_correlation)},
      {"rms_residual", r.rms_residual},
      {"residuals", r.residuals},
      {"iterations", r.iterations},
      {"evaluations", r.evaluations},
      {"runtime", r.runtime_s},
      {"forced", r.forced},
      {"noise", r.features.noise_rad},
      {"dof", r.dof},
      {"converged", r.converged},
      {"residual_to_noise", Optional(r.residual_to_noise)},
      {"chi2", Optional(r.chi2)},
      {"chi2_per_dof", Optional(r.chi2_per_dof)},
      {"p_value", Optional(r.p_value)},
      {"band_ratio", Optional(r.band_ratio)},
      {"band_p_value", Optional(r.band_p_value)},
      {"band_hz", Optional(r.band_hz)},
      {"significance", r.significance},
      {"noise_dof", Optional(r.noise_dof)},
      {"noise_stated", std::isinf(r.noise_dof)},
      {"starts", r.starts},
      {"starts_refined", r.starts_refined},
      {"noise_residual", Optional(r.noise_residual)},
      {"stderr_withheld", r.stderr_withheld},
      {"missing_samples", r.theta_gaps.missing_samples},
      {"gaps", r.theta_gaps.gaps},
      {"longest_gap", r.theta_gaps.longest_s},
      {"missing_table_samples", r.table_gaps.missing_samples},
      {"table_interpolation_error", Optional(r.table_interpolation_rad)},
      {"table_reading", r.forced ? nlohmann::json(model::TableReadingName(r.table_interpolation)) : nlohmann::json(nullptr)},
      {"release_time", r.method == model::FitMethod::kTrajectory ? Optional(r.release_time_s)
                                                                : Optional(r.features.release_time_s)},
      {"impacts", impacts},
      {"warnings", r.warnings},
      {"units",
       {{"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"}, {"alpha_stderr", "rad"},
        {"p_stderr", "rad/s"}, {"mu_stderr", "1"}, {"time", "s"}, {"peak", "rad"}, {"tau", "s"},
        {"residual", "s"}, {"rms_residual", r.method == model::FitMethod::kImpacts ? "s" : "rad"},
        {"noise_residual", r.method == model::FitMethod::kImpacts ? "s" : "rad"}, {"noise", "rad"},
        {"residual_to_noise", "1"}, {"chi2", "1"}, {"chi2_per_dof", "1"}, {"p_value", "1"}, {"band_ratio", "1"}, {"band_p_value", "1"}, {"band_hz", "Hz"}, {"residual_noise", "s"}, {"table_interpolation_error", "rad"}, {"longest_gap", "s"}, {"release_time", "s"}, {"runtime", "s"}}}};
  if (r.second_minimum) {
    j["second_minimum"] = {{"alpha", r.second_minimum->params.alpha},
                           {"p", r.second_minimum->params.p},
                           {"mu", r.second_minimum->params.mu},
                           {"delta_chi2", r.second_minimum->delta_chi2}};
  } else {
    j["second_minimum"] = nullptr;
  }
  if (r.theory) {
    j["theory"] = {{"alpha", r.theory->alpha}, {"p", r.theory->p}, {"mu", r.theory->mu}};
  } else {
    j["theory"] = nullptr;
  }
  if (r.band) {
    j["alpha_band"] = {{"lo", r.band->lo}, {"hi", r.band->hi}, {"band_m", r.band->band_m}};
  } else {
    j["alpha_band"] = nullptr;
  }
  return j;
}

void PrintText(std::FILE* out, const FitCliOptions& o, const model::FitResult& r) {
  std::fprintf(out, "rocklab fit: %s, method %s%s%s, %d residuals, %d iterations, %.2f s\n",
              o.input.c_str(), model::ToString(r.method),
              r.method == model::FitMethod::kImpacts ? ", quarter time " : "",
              r.method == model::FitMethod::kImpacts ? model::ToString(r.quarter_time) : "",
              r.residuals, r.iterations, r.runtime_s);
  std::fprintf(out, "\n%-10s %11s %11s %8s %10s\n", "", "alpha (rad)", "p (rad/s)", "mu", "mu_spread");
  std::fprintf(out, "%-10s %11.4f %11.4f %8.4f %10s\n", "fitted", r.params.alpha, r.params.p,
              r.params.mu, std::isfinite(r.mu_spread) ? std::to_string(r.mu_spread).substr(0, 6).c_str() : "-");
  auto stderr_cell = [](double v, const char* fmt) {
    char buf[32];
    if (!std::isfinite(v)) return std::string("-");
    std::snprintf(buf, sizeof buf, fmt, v);
    return std::string(buf);
  };
  std::fprintf(out, "%-10s %11s %11s %8s%s\n", "std error", stderr_cell(r.alpha_stderr, "%.4f").c_str(),
              stderr_cell(r.p_stderr, "%.4f").c_str(), stderr_cell(r.mu_stderr, "%.4f").c_str(),
              r.stderr_withheld ? "   (withheld: fewer than 3 degrees of freedom)" : "");
  if (r.theory) {
    std::fprintf(out, "%-10s %11.4f %11.4f %8.4f   (geometry)\n", "theory", r.theory->alpha, r.theory->p,
                r.theory->mu);
  }
  if (r.band) {
    std::fprintf(out, "admissible alpha [%.4f, %.4f] rad (b +- %.3g m)\n", r.band->lo, r.band->hi, r.band->band_m);
  }
  if (std::isfinite(r.alpha_p_correlation)) std::fprintf(out, "alpha-p correlation %.3f (%s)\n", r.alpha_p_correlation,
              std::abs(r.alpha_p_correlation) > 0.9
                  ? "strong: other (alpha, p) pairs along a ridge give nearly the same response"
                  : "moderate");
  const bool in_ms = r.method == model::FitMethod::kImpacts;
  std::fprintf(out, "rms residual %.3g %s, noise %.3g rad\n", in_ms ? r.rms_residual * 1e3 : r.rms_residual,
              in_ms ? "ms" : "rad", r.features.noise_rad);
  if (std::isfinite(r.residual_to_noise)) {
    std::fprintf(out, "residual / noise %.2f (the noise alone gives %.3g %s per residual): %s\n", r.residual_to_noise,
                in_ms ? r.noise_residual * 1e3 : r.noise_residual, in_ms ? "ms" : "rad",
                r.converged ? "converged" : "NOT converged");
    std::fprintf(out, "chi-square %.1f on %d degrees of freedom (%.3f per dof; noise %s), p = %.3g against "
                "significance %.3g; %d starts, %d refined\n",
                r.chi2, r.dof, r.chi2_per_dof,
                std::isinf(r.noise_dof) ? "stated" : ("estimated, " + std::to_string(static_cast<long>(r.noise_dof)) +
                                                      " dof").c_str(),
                r.p_value, r.significance, r.starts, r.starts_refined);
  } else {
    std::fprintf(out, "residual / noise not computable (%d degrees of freedom%s): %s\n", r.dof,
                r.features.noise_rad > 0.0 ? "" : ", no measurable noise",
                r.converged ? "converged (least squares)" : "NOT converged");
  }
  if (r.theta_gaps.missing_samples > 0) {
    std::fprintf(out, "missing samples %lld in %lld gap(s)\n", static_cast<long long>(r.theta_gaps.missing_samples),
                static_cast<long long>(r.theta_gaps.gaps));
  }
  if (r.release_time_s) std::fprintf(out, "fitted release time %.4f s\n", *r.release_time_s);
  if (!r.impacts.empty()) {
    std::fprintf(out, "\n%3s %10s %11s %8s %9s %13s\n", "n", "time (s)", "peak (rad)", "mu_n", "tau* (s)",
                "residual (ms)");
    auto cell = [](const std::optional<double>& v, const char* fmt, double scale) {
      char buf[32];
      if (!v) return std::string("-");
      std::snprintf(buf, sizeof buf, fmt, *v * scale);
      return std::string(buf);
    };
    for (const model::ImpactRow& row : r.impacts) {
      std::fprintf(out, "%3d %10s %11s %8s %9s %13s\n", row.n,
                  std::isfinite(row.time_s) ? cell(row.time_s, "%.4f", 1).c_str() : "-",
                  cell(row.peak_rad, "%.5f", 1).c_str(), cell(row.mu_n, "%.4f", 1).c_str(),
                  cell(row.tau_s, "%.4f", 1).c_str(), cell(row.residual_s, "%+.3f", 1e3).c_str());
    }
  }
  for (const std::string& w : r.warnings) std::fprintf(out, "note: %s\n", w.c_str());
}

int RunFit(const FitCliOptions& o) {
  model::FitOptions fo;
  try {
    fo.quarter_time = model::ParseQuarterTime(o.quarter_time);
  } catch (const std::invalid_argument&) {
    throw UsageError("--quarter-time must be exact or slender, got '" + o.quarter_time + "'");
  }
  model::FitMethod method{};
  try {
    method = model::ParseFitMethod(o.method);
  } catch (const std::invalid_argument&) {
    throw UsageError("--method must be impacts or trajectory, got '" + o.method + "'");
  }
  Require(o.alpha_band_m >= 0.0, "--alpha-band-m", ">= 0 m", o.alpha_band_m);
  Require(o.min_impacts >= 3, "--min-impacts", ">= 3", o.min_impacts);
  Require(o.rtol > 0.0 && o.rtol < 1e-3, "--rtol", "in (0, 1e-3)", o.rtol);
  fo.rtol = o.rtol;
  Require(o.noise_rad >= 0.0, "--noise-rad", ">= 0 rad", o.noise_rad);
  Require(o.significance > 0.0 && o.significance < 0.5, "--significance", "in (0, 0.5)", o.significance);
  Require(o.starts >= -1, "--starts", ">= 0", o.starts);
  // Output paths checked before the work (the fit can take minutes).
  RequireOutputFolder("--out", o.out_json);
  RequireOutputFolder("--samples", o.samples);
  RequireOutputFolder("--plot", o.plot);
  RequireOneStandardOutput({{"--out", o.out_json}, {"--samples", o.samples}, {"--plot", o.plot}});
  fo.features.noise_rad = o.noise_rad;
  fo.significance = o.significance;
  fo.starts = o.starts;
  try {
    fo.table_interpolation = model::ParseTableReading(o.table);
  } catch (const std::invalid_argument&) {
    throw UsageError("--table must be spline or chord, got '" + o.table + "'");
  }
  fo.alpha_band_m = o.alpha_band_m;
  fo.min_impacts = o.min_impacts;

  const bool has_dims = o.width_m != 0.0 || o.height_m != 0.0;
  if (!o.rig.empty() && has_dims) throw UsageError("give either --rig or --width/--height, not both");
  if (!o.rig.empty()) {
    daq::RigConfig rig;
    try {
      rig = daq::LoadRigConfig(o.rig);
    } catch (const std::exception& e) {
      throw UsageError(e.what());
    }
    if (!(rig.block.width_m > 0.0 && rig.block.height_m > 0.0)) {
      throw UsageError("--rig " + o.rig + " has no block geometry (block.width_m, block.height_m)");
    }
    fo.geometry = model::FitGeometry{rig.block.width_m, rig.block.height_m, rig.block.chamfer_m};
    for (const auto& xz : rig.block.polygon_m) fo.geometry->polygon_m.emplace_back(xz[0], xz[1]);
    if (!rig.block.polygon_m.empty()) {
      try {
        (void)model::PolygonBlock(fo.geometry->polygon_m);
      } catch (const std::invalid_argument& e) {
        throw UsageError(o.rig + ":" + std::to_string(rig.block.polygon_line) + ": key 'block.polygon' " +
                         std::string(e.what()).substr(std::string(e.what()).rfind("vertices_m: ", 0) == 0 ? 12 : 0));
      }
    }
  } else if (has_dims) {
    Require(o.width_m > 0.0, "--width", "> 0 m", o.width_m);
    Require(o.height_m > 0.0, "--height", "> 0 m", o.height_m);
    Require(o.chamfer_m >= 0.0, "--chamfer", ">= 0 m", o.chamfer_m);
    fo.geometry = model::FitGeometry{o.width_m, o.height_m, o.chamfer_m};
  }
  if (fo.geometry) {
    try {
      (void)model::AdmissibleAlphaBand(*fo.geometry, fo.alpha_band_m);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("geometry: ") + e.what());
    }
  }

  model::PosteriorOptions po;
  if (o.posterior) {
    if (!fo.geometry) throw UsageError("--posterior needs the block geometry (--rig or --width/--height): the priors come from it");
    Require(o.walkers >= 2, "--walkers", ">= 2", o.walkers);
    Require(o.steps >= 8, "--steps", ">= 8", o.steps);
    Require(o.threads >= 0, "--threads", ">= 0", o.threads);
    Require(o.posterior_rtol > 0.0 && o.posterior_rtol < 1e-3, "--posterior-rtol", "in (0, 1e-3)", o.posterior_rtol);
    Require(o.burn_in >= -1 && o.burn_in < o.steps - 3, "--burn-in", "in [0, steps - 4] (or -1: half the steps)",
            o.burn_in);
    try {
      po.model = model::ParseModelKind(o.model);
    } catch (const std::invalid_argument&) {
      throw UsageError("--model must be " + model::ModelNames(" or ") + ", got '" + o.model + "'");
    }
    if (o.integrator != "adams" && o.integrator != "rk") {
      throw UsageError("--integrator must be adams or rk, got '" + o.integrator + "'");
    }
    po.integrator = o.integrator == "rk" ? model::Integrator::kRungeKutta : model::Integrator::kAdams;
    if (o.per_impact_mu && method != model::FitMethod::kImpacts) {
      throw UsageError("--per-impact-mu needs --method impacts (the trajectory likelihoods have one mu)");
    }
    if (po.model == model::ModelKind::kComplex && method != model::FitMethod::kTrajectory) {
      throw UsageError("--model complex needs --method trajectory (the impacts likelihood is Housner's closed form)");
    }
    po.method = method;
    po.rtol = o.posterior_rtol;
    po.sampler.seed = o.seed;
    po.sampler.walkers = o.walkers;
    po.sampler.steps = o.steps;
    po.sampler.threads = o.threads;
    po.burn_in = o.burn_in;
    po.priors.per_impact_mu = o.per_impact_mu;
    po.priors.alpha_band_m = fo.alpha_band_m > 0.0 ? fo.alpha_band_m : po.priors.alpha_band_m;
    if (!o.rig.empty()) {
      const daq::PosteriorPriorConfig c = daq::LoadRigConfig(o.rig).posterior;
      model::PosteriorPriors& pr = po.priors;
      pr.alpha_band_m = c.alpha_band_m.value_or(pr.alpha_band_m);
      pr.p_range = c.p_range.value_or(pr.p_range);
      pr.mu_min = c.mu_min.value_or(pr.mu_min);
      pr.mu_max = c.mu_max.value_or(pr.mu_max);
      pr.log10_l_min = c.log10_l_min.value_or(pr.log10_l_min);
      pr.log10_l_max = c.log10_l_max.value_or(pr.log10_l_max);
      pr.t_offset_s = c.t_offset_s.value_or(pr.t_offset_s);
      pr.per_impact_mu = pr.per_impact_mu || c.sigma_mu_max.has_value();
      pr.sigma_mu_max = c.sigma_mu_max.value_or(pr.sigma_mu_max);
    }
  }

  model::FitResult result;
  std::optional<model::PosteriorResult> posterior;
  std::string record_path = o.input, accel_path = o.accel_csv;  // the files read (- : its copy)
  try {
    model::RockingRecord record;
    {
      common::FileProgress progress("fit", o.input, o.quiet);  // the record's read
      record_path = InputFile("RECORD", o.input);
      record = model::ReadRecord(record_path);
    }
    if (!o.accel_csv.empty()) {
      accel_path = InputFile("--accel", o.accel_csv);
      model::AddTableCsv(accel_path, record);
    }
    model::WindowRecord(record, o.start_s, o.end_s);
    {
      // The model runs so far on the commands' progress line (a terminal
      // only; how many the fit needs is not known before it converges).
      common::Progress bar("fit", 0, o.quiet || method != model::FitMethod::kTrajectory, 2, "model runs");
      if (bar.active()) fo.on_progress = [&bar](const model::FitProgress& p) { bar.Update(p.evaluations); };
      result = method == model::FitMethod::kImpacts ? model::FitImpacts(record, fo)
                                                    : model::FitTrajectory(record, fo);
      fo.on_progress = nullptr;
    }
    if (o.posterior) {
      po.fit = fo;
      po.fit.on_progress = nullptr;
      common::Progress bar("posterior", po.sampler.steps, o.quiet, 2, "steps");
      if (bar.active()) po.sampler.on_step = [&bar](int step, int) { bar.Update(step); };
      const model::PosteriorProblem problem(record, po, &result);
      posterior = model::SamplePosterior(problem, po);
      po.sampler.on_step = nullptr;
    }
  } catch (const model::RecordError& e) {
    throw UsageError(e.what());
  } catch (const model::FitError& e) {
    throw UsageError(e.what());
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }

  nlohmann::json j = ResultJson(o, result);
  // What made the result (version, command, time, sources with size and
  // SHA-256; standard input's as <stdin>): in the JSON, as run's summary.
  const common::Provenance made = common::MakeProvenance({record_path, o.rig, accel_path});
  j["provenance"] = nlohmann::json::parse(common::ProvenanceJson(made));
  if (posterior) {
    j["posterior"] = nlohmann::json::parse(model::PosteriorJson(*posterior));
    const auto provenance = common::ProvenanceFields(made);
    if (!o.samples.empty()) WritePosteriorSamples(o.samples, *posterior, provenance);
    if (!o.plot.empty()) {  // - : the SVG, its provenance inside, to standard output once complete
      OutputTarget plot("--plot", o.plot, ".svg");
      WriteCornerSvg(plot.path(), *posterior, "rocklab fit --posterior: " + o.input, provenance);
      plot.Finish();
    }
  }
  // One object for --out FILE (- : standard output) and --json.
  // With the draws or the plot on standard output (--samples -, --plot -)
  // the summary and --json go to stderr, as simulate's with --out -.
  const bool samples_out = posterior && (o.samples == "-" || o.plot == "-");
  WriteResult(j, o.json, o.out_json, samples_out, "--out");
  if (!o.json && o.out_json != "-") {
    PrintText(samples_out ? stderr : stdout, o, result);
    if (posterior) PrintPosterior(samples_out ? stderr : stdout, *posterior);
  }
  int code = 0;
  if (!result.converged) {
    // The point fit's verdict (docs/commands.md, "converged"): the result is
    // written, the work failed.
    const std::string why = common::Format("the model does not follow the record within its noise or the search stopped "
                                   "(chi-square p = %.3g%s, significance %.3g)",
                                   result.p_value,
                                   std::isfinite(result.band_p_value)
                                       ? common::Format(", band p = %.3g", result.band_p_value).c_str()
                                       : "",
                                   result.significance);
    if (!o.allow_unconverged) {
      std::fprintf(stderr, "rocklab fit: the fit has not converged: %s (--allow-unconverged: exit 0)\n", why.c_str());
      code = kUnconvergedExit;
    } else {
      std::fprintf(stderr, "rocklab fit: warning: the fit has not converged: %s\n", why.c_str());
    }
  }
  if (posterior && !posterior->converged()) {
    std::string why;
    for (const std::string& p : posterior->problems) why += (why.empty() ? "" : "; ") + p;
    if (!o.allow_unconverged) {
      std::fprintf(stderr, "rocklab fit: the posterior has not converged: %s (more --steps, or --allow-unconverged)\n",
                   why.c_str());
      return kUnconvergedExit;
    }
    std::fprintf(stderr, "rocklab fit: warning: the posterior has not converged: %s\n", why.c_str());
  }
  return code;
}

}  // namespace

void RegisterFit(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<FitCliOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("fit", "fit alpha, p, mu to a recorded test (impacts or trajectory)");
  cmd->add_option("input,--input", opts->input,
                  "CSV with header time,theta (s, rad; extra columns allowed) or rocklab LCM log "
                  "(RL_THETA, RL_TABLE)")
      ->required();
  cmd->add_option("--rig", opts->rig, "rig TOML giving the block geometry");
  cmd->add_option("--width", opts->width_m, "block width 2b, m");
  cmd->add_option("--height", opts->height_m, "block height 2h, m");
  cmd->add_option("--chamfer", opts->chamfer_m, "45 degree base chamfer leg, m");
  cmd->add_option("--start", opts->start_s,
                  "fit only from this time on, s from the record's first sample (default 0): e.g. the free "
                  "rocking after a forced test's table stopped");
  cmd->add_option("--end", opts->end_s, "fit only up to this time, s from the record's first sample (default: to "
                                        "the end)");
  cmd->add_option("--accel", opts->accel_csv, "table acceleration of a CSV record: " + FormatsHelp(DataKind::kGroundMotion));
  cmd->add_option("--method", opts->method, "impacts (paper, free rocking) | trajectory (whole record)");
  cmd->add_option("--quarter-time", opts->quarter_time, "impacts method: exact (corrected eq. 12) | slender (eq. 13)");
  cmd->add_option("--alpha-band-m", opts->alpha_band_m, "admissible error on b, m (default 0.01)");
  cmd->add_option("--min-impacts", opts->min_impacts, "fewest impacts accepted (default 4)");
  cmd->add_option("--rtol", opts->rtol, "trajectory method: the model's relative tolerance, in (0, 1e-3) (default 1e-8)");
  cmd->add_option("--noise-rad", opts->noise_rad,
                  "white-noise standard deviation of theta, rad, taken as exact (default: estimated from the record)");
  cmd->add_option("--significance", opts->significance,
                  "level of the chi-square goodness-of-fit test behind 'converged', in (0, 0.5) (default 0.01)");
  cmd->add_option("--starts", opts->starts,
                  "trajectory: prior-box starts screened (default 24); impacts: alpha-profile minima refined (default 3)");
  cmd->add_option("--table", opts->table,
                  "forced trajectory fit and posterior: the table record between its samples, spline (point "
                  "samples, as a DAQ records them) | chord (least-squares chord values, as `track` merges them "
                  "at the camera's rate) (default spline)");
  cmd->add_flag("--json", opts->json, "print the result as JSON");
  cmd->add_flag("--quiet", opts->quiet, "no progress line on stderr (drawn when stderr is a terminal)");
  cmd->add_option("--out", opts->out_json,
                  "write the result JSON (top-level alpha, p, mu) to this file (- : standard output, without the "
                  "text summary)");
  cmd->add_flag("--posterior", opts->posterior,
                "also sample the posterior of alpha, p, mu (, l), sigma, t_offset (docs/identification.md)");
  cmd->add_option("--seed", opts->seed, "posterior: random seed (default 1)");
  cmd->add_option("--walkers", opts->walkers, "posterior: ensemble walkers, even, >= 2 x parameters (default 32)");
  cmd->add_option("--steps", opts->steps, "posterior: steps per walker (default 5000)");
  cmd->add_option("--burn-in", opts->burn_in, "posterior: steps dropped first (default -1: half the steps)");
  cmd->add_option("--threads", opts->threads, "posterior: threads (default 0: all cores)");
  cmd->add_option("--model", opts->model, "posterior, trajectory method: housner | complex (samples l too)");
  cmd->add_option("--posterior-rtol", opts->posterior_rtol,
                  "posterior, trajectory method: the model's relative tolerance (default 1e-6)");
  cmd->add_option("--integrator", opts->integrator, "posterior, trajectory method: adams | rk (default adams)");
  cmd->add_option("--samples", opts->samples, "posterior: write the draws, FILE.csv or FILE.h5");
  cmd->add_option("--plot", opts->plot, "posterior: write the corner plot, FILE.svg");
  cmd->add_flag("--per-impact-mu", opts->per_impact_mu,
                "posterior, impacts method: a restitution per impact, mu_n ~ N(mu, sigma_mu^2), sigma_mu sampled "
                "(its prior: the rig's posterior.sigma_mu_max, default 0.1)");
  cmd->add_flag("--allow-unconverged", opts->allow_unconverged,
                "exit 0 even when the fit is not converged or the posterior fails its convergence rule (else "
                "exit code 1; the results are written either way)");
  cmd->callback([opts, &run] { run = [opts] { return RunFit(*opts); }; });
}

}  // namespace rocklab::tools
