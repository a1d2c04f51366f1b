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

std::vector<std::pair<std::string, std::string>> RigUnits(const std::string& rig_path) {
  std::vector<std::pair<std::string, std::string>> units;
  if (rig_path.empty()) return units;
  for (const auto& c : pipeline::LoadRig(rig_path).channels) units.emplace_back(c.name, c.unit);
  return units;
}

int RunInfo(const InfoOptions& o) {
  Require(o.rate_hz >= 0, "--rate", ">= 0 Hz", o.rate_hz);
  std::string text;
  try {
    if (InfoOfOtherFormats(o.input, o.json, text)) {
      // a ground-motion record or a sweep's results (cmd_info_formats.cpp)
    } else if (exporter::IsLcmLog(o.input)) {
      const exporter::LogInfo info = exporter::ReadLogInfo(o.input);
      text = o.json ? exporter::JsonText(exporter::ToJson(info), 2) + "\n" : exporter::ToText(info);
    } else {
      const exporter::RawInfo info = exporter::ReadRawInfo(o.input, o.rate_hz, RigUnits(o.rig_path));
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
  cmd->add_option("input", opts->input,
                  "an LCM log (rocklab's or lcm-logger's), a raw .csv / .lvm, a ground-motion record: " +
                      FormatsHelp(DataKind::kGroundMotion) +
                      ", or sweep results: " + FormatsHelp(DataKind::kSweepResults))
      ->required();
  cmd->add_flag("--json", opts->json, "JSON instead of text (keys: docs/export.md)");
  cmd->add_option("--rig", opts->rig_path, "raw files: rig configuration (TOML) naming the channels' units");
  cmd->add_option("--rate", opts->rate_hz, "raw files without a time column: sample rate, Hz");
  cmd->callback([opts, &run] { run = [opts] { return RunInfo(*opts); }; });
}

}  // namespace rocklab::tools
