// rocklab info INPUT [--json] [--rig RIG.toml] [--rate HZ]: what a recorded
// LCM log or a raw CSV/LVM file holds (docs/export.md).
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "export/export.h"
#include "export/info.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"
#include "tools/formats.h"

namespace rocklab::tools {

bool InfoOfOtherFormats(const std::string& path, bool json, std::string& text);  // cmd_info_formats.cpp

namespace {

struct InfoOptions {
  std::string input;
  bool json{false};
  std::string rig_path;
  double rate_hz{0.0};
};


int RunInfo(const InfoOptions& o) {
  Require(o.rate_hz >= 0, "--rate", ">= 0 Hz", o.rate_hz);
  RefuseStandardInput("INPUT", o.input, "info tells the kind of a file from its name and first bytes");
  std::string text;
  try {
    if (InfoOfOtherFormats(o.input, o.json, text)) {
      // a ground-motion record or a sweep's results (cmd_info_formats.cpp)
    } else if (exporter::IsLcmLog(o.input)) {
      const exporter::LogInfo info = exporter::ReadLogInfo(o.input);
      text = o.json ? exporter::JsonText(exporter::ToJson(info), 2) + "\n" : exporter::ToText(info);
    } else {
      std::vector<std::pair<std::string, std::string>> units;
      double rig_rate_hz = 0;
      if (!o.rig_path.empty()) {
        const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
        for (const auto& c : rig.channels) units.emplace_back(c.name, c.unit);
        rig_rate_hz = rig.sample_rate_hz;
      }
      const exporter::RawRate rate = exporter::ChooseRawRate(o.rate_hz, "--rate", rig_rate_hz, o.rig_path);
      const exporter::RawInfo info = exporter::ReadRawInfo(o.input, rate.hz, units, rate.origin);
      text = o.json ? exporter::JsonText(exporter::ToJson(info), 2) + "\n" : exporter::ToText(info);
    }
  } catch (const UsageError&) {
    throw;
  } catch (const std::exception& e) {
    throw UsageError(std::string("INPUT: ") + e.what());
  }
  std::fputs(text.c_str(), stdout);
  return std::fflush(stdout) == 0 ? 0 : kFailureExit;
}

}  // namespace

void RegisterInfo(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<InfoOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("info", "what a recorded LCM log, a raw CSV/LVM file, a ground-motion record or sweep results hold");
  cmd->add_option("input,--input", opts->input,
                  "an LCM log (rocklab's or lcm-logger's), a raw .csv / .lvm, a ground-motion record: " +
                      FormatsHelp(DataKind::kGroundMotion) +
                      ", or sweep results: " + FormatsHelp(DataKind::kSweepResults))
      ->required();
  cmd->add_flag("--json", opts->json, "JSON instead of text (keys: docs/export.md)");
  cmd->add_option("--rig", opts->rig_path,
                  "raw files: rig configuration (TOML) naming the channels' units (its sample_rate_hz is checked "
                  "against the file's time column)");
  cmd->add_option("--rate", opts->rate_hz,
                  "raw files: sample rate, Hz; needed without a time column, else checked against it");
  cmd->callback([opts, &run] { run = [opts] { return RunInfo(*opts); }; });
}

}  // namespace rocklab::tools
