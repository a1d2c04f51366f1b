// rocklab sweep: every (record, block, scale) case of a campaign, one row
// each; rocklab sweep-plot: its spectra, overturning maps and fragility.
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/provenance.h"
#include "sweep/plot.h"
#include "sweep/row_writer.h"
#include "sweep/runner.h"
#include "sweep/sweep.h"
#include "tools/cli.h"
#include "tools/formats.h"
#include "pipeline/scenario_flags.h"

namespace rocklab::tools {
namespace {

static_assert(sweep::Plan::kDefaultTail_s == pipeline::kDefaultTail_s, "simulate --accel and sweep: the same default tail");

struct SweepCommandOptions {
  sweep::PlanOptions plan;
  double duration_s{-1};  // < 0: not given
  std::string out;
  unsigned threads{0};
  std::string shard;
  bool resume{};
  std::vector<std::string> merge;
  bool json{};
};

sweep::Slice ParseShard(const std::string& text, std::size_t plan_size) {
  sweep::Slice slice{0, 1, plan_size};
  if (text.empty()) return slice;
  const std::string what = "--shard must be I/N with 0 <= I < N (e.g. 3/16), got '" + text + "'";
  const auto slash = text.find('/');
  if (slash == std::string::npos || slash == 0 || slash + 1 == text.size()) throw UsageError(what);
  const std::string i = text.substr(0, slash), n = text.substr(slash + 1);
  if (i.find_first_not_of("0123456789") != std::string::npos ||
      n.find_first_not_of("0123456789") != std::string::npos || i.size() > 9 || n.size() > 9) {
    throw UsageError(what);
  }
  slice.first = std::stoul(i);
  slice.stride = std::stoul(n);
  if (slice.stride == 0 || slice.first >= slice.stride) throw UsageError(what);
  return slice;
}

int RunSweepCommand(SweepCommandOptions& o) {
  sweep::MpiSession mpi;
  if (o.duration_s >= 0) o.plan.duration_s = o.duration_s;
  for (std::string& record : o.plan.records) {
    if (record == "-" && mpi.size() > 1) throw UsageError("--records -: each rank reads the records; give the file");
    record = InputFile("--records", record);
  }
  RefuseStandardOutput("--out", o.resume ? o.out : "", "--resume reads back the rows already written");
  // --out -: the rows (CSV) on standard output once complete, the summary on stderr.
  OutputTarget out("--out", o.out, ".csv");
  std::FILE* summary = out.standard_output() ? stderr : stdout;
  struct RemovePartialRows {  // a stopped sweep's rows for -: nothing to --resume, not left in TMPDIR
    std::string path;
    ~RemovePartialRows() {
      if (!path.empty()) std::remove(path.c_str());
    }
  } partial_rows{out.standard_output() ? sweep::PartialPath(out.path()) : ""};
  const sweep::Plan plan = sweep::MakePlan(o.plan);
  if (!o.merge.empty()) {
    if (!o.shard.empty() || o.resume) throw UsageError("--merge takes neither --shard nor --resume");
    if (mpi.rank() != 0) return 0;
    // The merged file's provenance: this command and the shards it read.
    const sweep::MergeReport report =
        sweep::MergeShards(plan, o.merge, out.path(), common::ProvenanceFields(common::MakeProvenance(o.merge)));
    for (const std::string& w : report.warnings) std::fprintf(stderr, "rocklab: warning: --merge: %s\n", w.c_str());
    out.Finish();
    if (o.json) {
      WriteResult({{"merged", o.merge}, {"out", o.out}, {"rows", plan.size()}}, true, "", out.standard_output());
    } else {
      std::fprintf(summary, "sweep: merged %zu files into %s (%zu rows)\n", o.merge.size(), out.name().c_str(),
                   plan.size());
    }
    return 0;
  }
  sweep::RunOptions ro;
  ro.threads = o.threads;
  ro.slice = ParseShard(o.shard, plan.size());
  ro.resume = o.resume;
  ro.progress = mpi.rank() == 0 && isatty(STDERR_FILENO) != 0;
  if (mpi.rank() == 0) {  // the records and section files the cases read
    std::vector<std::string> sources = o.plan.records;
    sources.insert(sources.end(), o.plan.polygons.begin(), o.plan.polygons.end());
    if (!o.plan.assembly.empty()) sources.push_back(o.plan.assembly);
    ro.provenance = common::ProvenanceFields(common::MakeProvenance(sources));
  }
  const sweep::RunReport r = sweep::RunSweep(plan, out.path(), ro, mpi);
  if (r.open_failed_on_rank0) return kUsageExit;
  if (mpi.rank() != 0) return 0;
  out.Finish();
  if (o.json) {
    WriteResult({{"records", plan.records.size()},
                 {"blocks", plan.blocks.size()},
                 {"scales", plan.scales.size()},
                 {"cases", plan.size()},
                 {"shard", o.shard.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.shard)},
                 {"shard_cases", r.cases},
                 {"resumed", r.resumed},
                 {"run", r.run},
                 {"overturned", r.overturned},
                 {"beyond_pi_over_2", r.beyond_pi_over_2},
                 {"threads", r.threads},
                 {"ranks", r.ranks},
                 {"wall_time", r.wall_s},
                 {"out", o.out},
                 {"units", {{"wall_time", "s"}}}},
                true, "", out.standard_output());
  } else {
    std::fprintf(summary, "sweep: %zu records x %zu blocks x %zu scales = %zu cases%s; %zu kept (--resume), %zu run on %u threads x %d ranks in %.2f s, %zu overturned; rows in %s\n",
              plan.records.size(), plan.blocks.size(), plan.scales.size(), plan.size(),
              o.shard.empty() ? "" : (", shard " + o.shard + ": " + std::to_string(r.cases)).c_str(), r.resumed, r.run,
              r.threads, r.ranks, r.wall_s, r.overturned, out.name().c_str());
  }
  std::fflush(stdout);
  if (r.beyond_pi_over_2 > 0) {
    std::fprintf(stderr,
                 "rocklab: warning: %zu cases rocked past pi/2 without an overturn event (the model left its "
                 "domain; first: %s...): their rows are as computed, do not trust them\n",
                 r.beyond_pi_over_2, r.first_beyond_pi_over_2.c_str());
  }
  return 0;
}

// An interval's end in g, or "unbounded" where the likelihood leaves it open.
std::string Bound(double g, bool open) {
  if (open) return "unbounded";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g g", g);
  return buf;
}

struct PlotCommandOptions {
  std::string results;
  sweep::PlotOptions plot;
  std::string format{"svg"};
  bool json{};
};

// Each block's fit as --json gives it (the text summary's figures).
nlohmann::json FragilityJson(const sweep::BlockFragility& f) {
  auto bound = [](double g, bool open) { return open ? nlohmann::json(nullptr) : nlohmann::json(g); };
  nlohmann::json j = {{"model", f.model}, {"alpha", f.alpha}, {"p", f.p}, {"mu", f.mu}, {"rows", f.rows},
                      {"overturned", f.overturned}, {"status", sweep::ToString(f.fit.status)},
                      {"pga_g_min", f.pga_min_g}, {"pga_g_max", f.pga_max_g}};
  if (f.fit.status == sweep::FragilityFit::Status::kFitted) {
    j.update({{"median_g", f.fit.median},
              {"dispersion", f.fit.beta},
              {"median_g_low", bound(f.band.median_low, f.band.median_low_open)},
              {"median_g_high", bound(f.band.median_high, f.band.median_high_open)},
              {"caveat", f.caveat}});
  } else if (f.fit.status == sweep::FragilityFit::Status::kSeparated) {
    j.update({{"safe_below_g", f.fit.safe_below}, {"overturned_above_g", f.fit.overturned_above}});
  }
  if (!f.first_overturned.empty()) {  // an assembly's sweep: cases each body overturned first in
    nlohmann::json by_body = nlohmann::json::object();
    for (const auto& [body, count] : f.first_overturned) by_body[body] = count;
    j["first_overturned"] = by_body;
  }
  return j;
}

int RunSweepPlot(PlotCommandOptions& o) {
  if (o.format == "png") {
    o.plot.format = report::FigureFormat::kPng;
  } else if (o.format != "svg") {
    throw UsageError("--format must be svg or png, got '" + o.format + "'");
  }
  std::vector<sweep::ResultRow> rows;
  const std::string results = InputFile("RESULTS", o.results, ".csv", ".h5");
  try {
    rows = sweep::ReadResults(results);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  if (rows.empty()) throw UsageError(o.results + ": no rows");
  const std::vector<sweep::BlockFragility> fits = sweep::FitFragilities(rows);
  o.plot.provenance = common::ProvenanceFields(common::MakeProvenance({results}));  // --json's figures too
  if (o.json) {
    const sweep::PlotReport report = sweep::MakeFigures(rows, fits, o.plot);
    nlohmann::json blocks = nlohmann::json::array();
    for (const sweep::BlockFragility& f : fits) blocks.push_back(FragilityJson(f));
    WriteResult({{"results", o.results},
                 {"rows", rows.size()},
                 {"fragility", blocks},
                 {"files", report.files},
                 {"out_dir", o.plot.out_dir},
                 {"skipped_figures", report.skipped}},
                true);
    return 0;
  }
  std::printf("fragility (probability of overturning against PGA, lognormal fitted by maximum likelihood; "
              "PGAs tried per block in fragility.csv):\n");
  for (const sweep::BlockFragility& f : fits) {
    std::printf("  %s alpha %s rad, p %s rad/s, mu %s: %zu rows, %zu overturned: ", f.model.c_str(), f.alpha.c_str(),
                f.p.c_str(), f.mu.c_str(), f.rows, f.overturned);
    switch (f.fit.status) {
      case sweep::FragilityFit::Status::kFitted:
        std::printf("median %.4g g, dispersion %.4g; median 95 %% interval (profile likelihood) %s to %s\n",
                    f.fit.median, f.fit.beta, Bound(f.band.median_low, f.band.median_low_open).c_str(),
                    Bound(f.band.median_high, f.band.median_high_open).c_str());
        if (!f.caveat.empty()) std::printf("    caveat: %s\n", f.caveat.c_str());
        break;
      case sweep::FragilityFit::Status::kSeparated:
        std::printf("no finite fit (outcomes separated): median between %.4g and %.4g g, dispersion -> 0\n",
                    f.fit.safe_below, f.fit.overturned_above);
        break;
      case sweep::FragilityFit::Status::kNone:
        std::printf("none overturned, no fit\n");
        break;
      case sweep::FragilityFit::Status::kAll:
        std::printf("all overturned, no fit\n");
        break;
    }
    if (!f.first_overturned.empty()) {
      std::printf("    first to overturn:");
      for (std::size_t k = 0; k < f.first_overturned.size(); ++k) {
        std::printf("%s %s in %zu cases", k ? "," : "", f.first_overturned[k].first.c_str(), f.first_overturned[k].second);
      }
      std::printf("\n");
    }
  }
  const sweep::PlotReport report = sweep::MakeFigures(rows, fits, o.plot);
  std::printf("%zu files in %s", report.files.size(), o.plot.out_dir.c_str());
  if (report.skipped) std::printf(" (%zu figures skipped: more than %zu of a kind)", report.skipped, o.plot.max_figures_per_kind);
  std::printf("\n");
  return 0;
}

}  // namespace

void RegisterSweep(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<SweepCommandOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("sweep", "overturning and peak rocking over records x blocks x scales");
  sweep::PlanOptions& p = opts->plan;
  cmd->add_option("--records", p.records, "ground-motion records (- : one CSV from standard input, named stdin.csv): " + FormatsHelp(DataKind::kGroundMotion))->required()->expected(1, -1);
  cmd->add_option("--scale", p.scale, "A:B:N, N values from A to B: factors on each record (default 1:1:1)");
  cmd->add_flag("--pga-g", p.pga_g, "the --scale values are the target PGA in g");
  cmd->add_option("--alpha", p.alpha, "blocks: alpha values, rad")->expected(1, -1);
  cmd->add_option("--p", p.p, "blocks: p values, rad/s")->expected(1, -1);
  cmd->add_option("--mu", p.mu, "blocks: mu values (default Housner's 1 - 1.5 sin^2 alpha)")->expected(1, -1);
  cmd->add_option("--width", p.width, "blocks: rectangle widths 2b, m")->expected(1, -1);
  cmd->add_option("--height", p.height, "blocks: rectangle heights 2h, m")->expected(1, -1);
  cmd->add_option("--polygon", p.polygons, "blocks: section files (x,z CSV, as rocklab params)")->expected(1, -1);
  cmd->add_option("--assembly", p.assembly,
                  "an assembly of bodies instead of the blocks (TOML, as simulate --assembly): a body or a frame "
                  "runs as its single block, a stack of 2-8 bodies by the stack model (housner); rows gain "
                  "first_overturned_body and peak_abs_theta_K (docs/sweep.md)");
  cmd->add_option("--model", p.model, "housner | complex")->required();
  cmd->add_option("--duration", opts->duration_s, "simulated time per case, s (default: record end + 10 s)");
  cmd->add_option("--rate", p.rate_hz, "rate at which peak theta is sampled, Hz (default 1000)");
  cmd->add_option("--l", p.l, "complex formulation momentum (default 1e-14)");
  cmd->add_option("--rtol", p.rtol, "CVODE relative tolerance, in (0, 1e-3] (default 1e-10)");
  cmd->add_option("--out", opts->out, "results: " + FormatsHelp(DataKind::kSweepResults) + " by the extension (--resume: CSV only; - : CSV on standard output)")->required();
  cmd->add_option("--threads", opts->threads, "worker threads (default: all cores; 1 per rank under mpirun)");
  cmd->add_option("--shard", opts->shard, "I/N: run cases I, I+N, I+2N, ... only (array jobs)");
  cmd->add_flag("--resume", opts->resume, "keep the complete rows already in --out and run the rest");
  cmd->add_option("--merge", opts->merge, "shard files to interleave into --out (same sweep options): " + FormatsHelp(DataKind::kSweepResults) + ", mixed as they come; --out CSV or HDF5 by its extension")->expected(1, -1);
  AddJsonFlag(*cmd, opts->json);
  cmd->callback([opts, &run] { run = [opts] { return RunSweepCommand(*opts); }; });

  auto plot = std::make_shared<PlotCommandOptions>();
  CLI::App* pc = app.add_subcommand("sweep-plot", "rocking spectra, overturning maps and fragility of a sweep");
  pc->add_option("results,--input", plot->results, "results of rocklab sweep: " + FormatsHelp(DataKind::kSweepResults) + " (- : standard input, CSV or HDF5)")->required();
  pc->add_option("--out-dir", plot->plot.out_dir, "folder for the figures and fragility.csv (default .)");
  pc->add_option("--format", plot->format, "svg (default) or png");
  pc->add_option("--gnuplot", plot->plot.gnuplot, "gnuplot program (default gnuplot)");
  AddJsonFlag(*pc, plot->json);
  pc->callback([plot, &run] { run = [plot] { return RunSweepPlot(*plot); }; });
}

}  // namespace rocklab::tools
