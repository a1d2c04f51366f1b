// rocklab export INPUT --out OUT.{csv,mat,h5} [--channels REGEX] [--start S]
// [--end S] [--rig RIG.toml] [--rate HZ] [--raw | --calibrated] [--quiet]: a recorded LCM log or a
// raw CSV/LVM file as tables for Python and MATLAB (docs/export.md).
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/progress.h"
#include "common/provenance.h"
#include "export/export.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct ExportCliOptions {
  std::string input;
  std::string out;
  exporter::ExportOptions options;
  std::string rig_path;
  bool quiet{false};
  bool raw{false};  // the default; named so that a script can say it
  bool json{false};
};

// --json: what the text summary says, as one object.
nlohmann::json ExportResultJson(const ExportCliOptions& o, const exporter::ExportSummary& s,
                                const std::vector<std::string>& files, bool log) {
  nlohmann::json tables = nlohmann::json::array();
  for (const auto& t : s.tables) {
    tables.push_back({{"channel", t.channel}, {"type", t.type}, {"rows", t.rows}, {"reshaped", t.reshaped}});
  }
  nlohmann::json j = {{"input", o.input},         {"kind", log ? "lcm_log" : "raw"},
                      {"files", files},           {"rows", s.rows},
                      {"tables", tables},         {"outside_window", s.outside_window}};
  if (log) {
    j.update({{"filtered", s.filtered},
              {"unknown_type", s.unknown_type},
              {"undecodable", s.undecodable},
              {"damaged_regions", s.damaged_regions},
              {"damaged_bytes", s.damaged_bytes},
              {"damaged_events", s.damaged_events}});
  } else {
    j.update({{"bad_rows", s.bad_rows},
              {"bad_values", s.bad_values},
              {"empty_values", s.empty_values},
              {"comments", s.comments},
              {"read_error", s.read_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.read_error)}});
  }
  return j;
}

int RunExport(ExportCliOptions& o) {
  try {
    o.options.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (o.out == "-") {
    throw UsageError("--out: export writes files by their extension (.csv per channel, .mat, .h5), not "
                     "standard output; give a file name");
  }
  RequireOutputFolder("--out", o.out);
  // The input first: a missing or unreadable one (a typo) stops here, before
  // any output exists. The sink writes beside --out and renames only at
  // Close, so a later failure leaves the previous file as it was too.
  RefuseStandardInput("INPUT", o.input, "export reads an LCM log by seeking and a raw file twice");
  if (std::FILE* probe = std::fopen(o.input.c_str(), "rb")) {
    std::fclose(probe);
  } else {
    throw UsageError("INPUT: cannot open '" + o.input + "': " + std::strerror(errno));
  }
  const bool log = exporter::IsLcmLog(o.input);
  if (!log && o.options.calibrated) {
    throw UsageError("--calibrated: logs only (RL_RAW's channel columns, calibrated by RL_DAQ_CONFIG); '" +
                     o.input + "' is a raw file, exported as it holds its values");
  }
  if (!o.rig_path.empty()) {
    const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
    for (const auto& c : rig.channels) {
      o.options.units.emplace_back(c.name, c.RawValuesUnit());  // raw values: not the calibrated unit
    }
    const exporter::RawRate rate =
        exporter::ChooseRawRate(o.options.sample_rate_hz, "--rate", rig.sample_rate_hz, o.rig_path);
    o.options.sample_rate_hz = rate.hz;
    o.options.rate_origin = rate.origin;
  }
  std::unique_ptr<exporter::TableSink> sink;
  try {
    sink = exporter::OpenSink(o.out, !log);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  long problems = 0;
  auto show = [&problems](const std::string& text) {
    if (++problems > kShownProblems) return;
    // Above the progress line, not through it.
    common::Progress::PrintAbove(2, [&text] { std::fprintf(stderr, "rocklab export: %s\n", text.c_str()); });
  };
  exporter::ExportSummary s;
  {
    common::FileProgress progress("export", o.input, o.quiet);
    try {
      s = log ? exporter::ExportLog(o.input, o.options, *sink, show)
              : exporter::ExportRaw(o.input, o.options, *sink, show);
    } catch (const exporter::InputError& e) {
      throw UsageError(std::string("INPUT: ") + e.what());
    }
  }
  if (log && s.tables.empty()) {
    // Nothing selected: an error, and no file (the sink is not closed, so a
    // previous file of that name stays as it was).
    std::fprintf(stderr,
                 "rocklab export: no message of %s is on a channel --channels '%s' selects (%lld left out); "
                 "nothing written; `rocklab info %s` lists its channels\n",
                 o.input.c_str(), o.options.channels.c_str(), static_cast<long long>(s.filtered), o.input.c_str());
    return kFailureExit;
  }
  // What made the file (hashed after the read: the input is in the page cache).
  for (const auto& [key, value] : common::ProvenanceFields(common::MakeProvenance({o.input, o.rig_path}))) {
    sink->DescribeFile(key, value);
  }
  sink->Close();
  if (problems > kShownProblems) {
    std::fprintf(stderr, "rocklab export: %ld more problems not shown\n", problems - kShownProblems);
  }
  std::string files;
  for (const std::string& f : sink->files()) files += (files.empty() ? "" : ", ") + f;
  if (o.json) WriteResult(ExportResultJson(o, s, sink->files(), log), true);
  if (log) {
    std::fprintf(stderr,
                 "rocklab export: %lld rows in %zu tables written to %s; %lld outside the window, "
                 "%lld of channels left out, %lld of unknown types, %lld undecodable\n",
                 static_cast<long long>(s.rows), s.tables.size(), files.empty() ? "(nothing)" : files.c_str(),
                 static_cast<long long>(s.outside_window), static_cast<long long>(s.filtered),
                 static_cast<long long>(s.unknown_type), static_cast<long long>(s.undecodable));
    for (const auto& t : s.tables) {
      if (t.reshaped > 0) {
        std::fprintf(stderr, "rocklab export: %s: %lld rows had arrays of another length than the first (cut or padded)\n",
                     t.channel.c_str(), static_cast<long long>(t.reshaped));
      }
    }
    return pipeline::ReportDamage(s.damaged_regions, s.damaged_bytes, s.damaged_events, o.input, "rocklab export",
                        "; the rest was exported") == 0
               ? 0
               : kFailureExit;
  }
  std::fprintf(stderr,
               "rocklab export: %lld rows written to %s; %lld outside the window, %lld bad rows skipped, "
               "%lld bad values and %lld empty values written as NaN, %lld comments kept\n",
               static_cast<long long>(s.rows), files.c_str(), static_cast<long long>(s.outside_window),
               static_cast<long long>(s.bad_rows), static_cast<long long>(s.bad_values),
               static_cast<long long>(s.empty_values), static_cast<long long>(s.comments));
  if (!s.read_error.empty()) {
    std::fprintf(stderr, "rocklab export: %s\n", s.read_error.c_str());
    return kFailureExit;
  }
  return 0;
}

}  // namespace

void RegisterExport(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<ExportCliOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("export", "a recorded LCM log or a raw CSV/LVM file as CSV, MAT or HDF5");
  cmd->add_option("input,--input", opts->input, "an LCM log (rocklab's or lcm-logger's), or a raw .csv / .lvm")
      ->required();
  cmd->add_option("--out", opts->out,
                  "OUT.csv (a log: OUT_<CHANNEL>.csv per channel), OUT.mat (MAT v5) or OUT.h5 (HDF5)")
      ->required();
  cmd->add_option("--channels", opts->options.channels, "logs: regex over whole channel names (default: all)");
  cmd->add_option("--start", opts->options.start_s, "s from the record's first sample (default 0)");
  cmd->add_option("--end", opts->options.end_s, "s from the record's first sample (default: to the end)");
  cmd->add_option("--rig", opts->rig_path, "raw files: rig configuration (TOML) naming the channels' units");
  cmd->add_option("--rate", opts->options.sample_rate_hz,
                  "raw files: sample rate, Hz; needed without a time column, else checked against it");
  auto* raw = cmd->add_flag("--raw", opts->raw,
                             "logs: RL_RAW's channel-named columns hold the raw values (the default)");
  cmd->add_flag("--calibrated", opts->options.calibrated,
                "logs: RL_RAW's channel-named columns hold gain * raw + offset in the channel's unit "
                "(RL_DAQ_CONFIG); values_0.. stay raw either way")
      ->excludes(raw);
  cmd->add_flag("--quiet", opts->quiet, "no progress bar");
  AddJsonFlag(*cmd, opts->json);
  cmd->callback([opts, &run] { run = [opts] { return RunExport(*opts); }; });
}

}  // namespace rocklab::tools
