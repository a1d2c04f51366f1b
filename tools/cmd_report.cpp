// rocklab report LOG.lcm --out report.html [--png FILE] [--svg FILE]
// [--size WxH] [--series-rate HZ] [--max-points N] [--start S] [--end S]:
// a recorded test (or a time window of it) as a self-contained page
// (the live monitor's views over the whole record) and a static figure like
// the paper's figures 6 to 8.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <regex>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/progress.h"
#include "common/provenance.h"
#include "common/text.h"
#include "tools/cli.h"
#include "pipeline/pipeline.h"
#include "report/report.h"

namespace rocklab::tools {
namespace {

using report::FigureFormat;
using report::ReadRecordLog;
using report::RecordReport;
using report::ReportFigure;
using report::ReportInputError;
using report::ReportOptions;
using report::ReportPage;
using report::ThetaFigure;

struct ReportCommand {
  std::string log_path;
  std::string out_html;
  std::string png_path;
  std::string svg_path;
  std::string size{"1000x650"};
  std::string series_rate{"100"};  // Hz, or "model"
  long long max_points{20000};
  ReportOptions options;
  bool quiet{};
  bool json{};
};

// A slot of 1 us, the log's time resolution: every sample of each series
// (at the model's, the DAQ's, the comparator's own rate) up to --max-points.
constexpr double kEverySampleRateHz = 1e6;

// --series-rate: a rate in Hz, or `model` for every sample as published.
double ParseSeriesRate(const std::string& text) {
  if (text == "model") return kEverySampleRateHz;
  double hz = 0.0;
  if (!common::ParseDouble(text, hz)) {
    throw UsageError("report: --series-rate: '" + text + "' is not a number (Hz) or 'model'");
  }
  Require(hz > 0 && std::isfinite(hz), "--series-rate", "> 0 Hz", hz);
  return hz;
}

std::pair<int, int> ParseSize(const std::string& text) {
  static const std::regex kSize("([0-9]{1,5})x([0-9]{1,5})");
  std::smatch m;
  if (!std::regex_match(text, m, kSize) || std::stoi(m[1]) < 200 || std::stoi(m[2]) < 200) {
    throw UsageError("--size must be WIDTHxHEIGHT in pixels, each at least 200, got '" + text + "'");
  }
  return {std::stoi(m[1]), std::stoi(m[2])};
}

// Written beside and renamed when complete: a failed write leaves a
// previous page as it was.
void WriteText(const std::string& path, const std::string& text) { common::WriteFileAtomically(path, text); }

void DrawFigure(const ThetaFigure& figure, const OutputTarget& target, FigureFormat format,
                std::pair<int, int> size) {
  if (target.path().empty()) return;
  std::string warnings;
  try {
    warnings = figure.Write(target.path(), format, size.first, size.second);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--size: ") + e.what());
  }
  if (!warnings.empty()) std::fprintf(stderr, "report: gnuplot: %s\n", warnings.c_str());
  std::fprintf(stderr, "report: wrote %s\n", target.name().c_str());
}

int RunReport(ReportCommand& c) {
  const std::pair<int, int> size = ParseSize(c.size);
  c.options.series_rate_hz = ParseSeriesRate(c.series_rate);
  Require(c.max_points >= 16 && c.max_points <= 10000000, "--max-points", ">= 16 and <= 1e7",
          static_cast<double>(c.max_points));
  c.options.max_points = static_cast<std::size_t>(c.max_points);
  Require(c.options.start_s >= 0 && std::isfinite(c.options.start_s), "--start", ">= 0 s",
          c.options.start_s);
  Require(c.options.end_s > c.options.start_s, "--end", "> --start (s)", c.options.end_s);
  RefuseStandardInput("LOG", c.log_path, "an LCM log is read by seeking in it");
  RequireOneStandardOutput({{"--out", c.out_html}, {"--svg", c.svg_path}, {"--png", c.png_path}});
  RequireOutputFolder("--out", c.out_html);
  RequireOutputFolder("--png", c.png_path);
  RequireOutputFolder("--svg", c.svg_path);

  RecordReport record;
  try {
    common::FileProgress progress("report", c.log_path, c.quiet);
    record = ReadRecordLog(c.log_path, c.options);
  } catch (const ReportInputError& e) {
    throw UsageError(e.what());
  }
  std::fprintf(stderr, "report: %s: %lld events, %lld that did not decode\n", c.log_path.c_str(),
               static_cast<long long>(record.events), static_cast<long long>(record.decode_errors));
  if (record.seq_missing > 0) {
    std::fprintf(stderr, "report: %lld messages missing by their sequence numbers (lost before the log): %s\n",
                 static_cast<long long>(record.seq_missing),
                 record.snapshot.at("counters").at("seq_missing").dump().c_str());
  }
  for (const std::string& problem : record.problems) std::fprintf(stderr, "report: %s\n", problem.c_str());
  pipeline::ReportDamage(record.damaged_regions, record.damaged_bytes, record.damaged_events,
                         c.log_path, "report", "; the page shows the rest");
  std::int64_t dropped = 0;
  for (const auto& [what, n] : record.snapshot.at("counters").at("dropped").items()) {
    dropped += n.get<std::int64_t>();
  }
  if (dropped > 0) {
    std::fprintf(stderr, "report: %lld items beyond the page's limits were left out: %s\n",
                 static_cast<long long>(dropped),
                 record.snapshot.at("counters").at("dropped").dump().c_str());
  }
  const int records = record.snapshot.value("record", 1);
  if (records > 1) {
    std::fprintf(stderr,
                 "report: the sample clock goes back %d times in the log (a replay restarted?): "
                 "the report shows the last record only\n",
                 records - 1);
  }

  // Each output a file written whole, or (-) standard output once complete.
  OutputTarget html("--out", c.out_html, ".html"), svg("--svg", c.svg_path, ".svg"), png("--png", c.png_path, ".png");
  record.provenance = common::ProvenanceFields(common::MakeProvenance({c.log_path}));
  WriteText(html.path(), ReportPage(record));
  std::fprintf(stderr, "report: wrote %s\n", html.name().c_str());
  if (!c.svg_path.empty() || !c.png_path.empty()) {
    ThetaFigure figure = ReportFigure(record);
    figure.set_provenance(record.provenance);  // SVG metadata, PNG tEXt chunks
    DrawFigure(figure, svg, FigureFormat::kSvg, size);
    DrawFigure(figure, png, FigureFormat::kPng, size);
  }
  for (OutputTarget* out : {&html, &svg, &png}) out->Finish();
  if (c.json) {
    auto file = [](const std::string& path) { return path.empty() ? nlohmann::json(nullptr) : nlohmann::json(path); };
    WriteResult({{"log", c.log_path},
                 {"out", c.out_html},
                 {"svg", file(c.svg_path)},
                 {"png", file(c.png_path)},
                 {"events", record.events},
                 {"decode_errors", record.decode_errors},
                 {"seq_missing", record.seq_missing},
                 {"dropped", dropped},
                 {"records", records},
                 {"problems", record.problems},
                 {"damaged_regions", record.damaged_regions},
                 {"damaged_bytes", record.damaged_bytes},
                 {"damaged_events", record.damaged_events},
                 {"config", record.snapshot.value("config", nlohmann::json(nullptr))},
                 {"counters", record.snapshot.value("counters", nlohmann::json(nullptr))},
                 {"peak_table_accel", record.table.accel_mps2},
                 {"peak_table_disp", record.table.disp_m},
                 {"units", {{"peak_table_accel", "m/s^2"}, {"peak_table_disp", "m"}, {"damaged_bytes", "bytes"}}}},
                true, "", html.standard_output() || svg.standard_output() || png.standard_output());
  }
  return record.damaged_regions == 0 ? 0 : kFailureExit;
}

}  // namespace

void RegisterReport(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<ReportCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("report", "a recorded test as a web page and a figure");
  cmd->add_option("log,--input", c->log_path, "LCM log of the test (rocklab run --log, lcm-logger)")
      ->required();
  cmd->add_option("--out", c->out_html, "the page (HTML, self-contained; - : standard output)")->required();
  cmd->add_option("--png", c->png_path, "the figure as PNG (- : standard output)");
  cmd->add_option("--svg", c->svg_path, "the figure as SVG (- : standard output)");
  cmd->add_option("--size", c->size, "figure size WIDTHxHEIGHT, px")->capture_default_str();
  cmd->add_option("--series-rate", c->series_rate,
                  "points kept per second of each series, Hz; model: every sample as published (the error "
                  "at the model's rate), up to --max-points")
      ->capture_default_str();
  cmd->add_flag("--quiet", c->quiet, "no progress bar (drawn when stderr is a terminal)");
  AddJsonFlag(*cmd, c->json);
  cmd->add_option("--max-points", c->max_points,
                  "points per series at most (a longer record is shown coarser)")
      ->capture_default_str();
  cmd->add_option("--start", c->options.start_s,
                  "start of the window, s after the record's first sample")
      ->capture_default_str();
  cmd->add_option("--end", c->options.end_s,
                  "end of the window, s after the record's first sample (default: the end)");
  cmd->callback([c, &run] { run = [c] { return RunReport(*c); }; });
}

}  // namespace rocklab::tools
