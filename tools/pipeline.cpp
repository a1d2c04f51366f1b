#include "tools/pipeline.h"

#include <cmath>

#include "model/block.h"
#include "tools/cli.h"

namespace rocklab::tools {

daq::RigConfig LoadRig(const std::string& path) {
  try {
    return daq::LoadRigConfig(path);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--rig: ") + e.what());
  }
}

model::BlockParams TheoreticalParams(const daq::RigConfig& rig) {
  return model::RectangleBlock(rig.block.width_m, rig.block.height_m, rig.block.chamfer_m).params();
}

std::vector<model::VariantSpec> BuildVariants(const std::vector<std::string>& texts,
                                              const daq::RigConfig& rig) {
  const model::BlockParams theory = TheoreticalParams(rig);
  std::vector<std::string> specs = texts;
  if (specs.empty()) specs = {"housner:housner:theoretical", "complex:complex:theoretical"};
  std::vector<model::VariantSpec> out;
  for (const std::string& s : specs) {
    try {
      out.push_back(model::ParseVariant(s, theory));
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--variant: ") + e.what());
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (out[i].name == out[j].name) {
        throw UsageError("--variant: name '" + out[i].name + "' used twice");
      }
    }
  }
  return out;
}

void AddCompareOptions(CLI::App& cmd, compare::CompareNodeConfig& c) {
  cmd.add_option("--compare-rate", c.publish_rate_hz, "RL_COMPARE_* rate, sample-clock Hz")
      ->capture_default_str();
  cmd.add_option("--window", c.comparator.window_s, "sliding RMS window, s")->capture_default_str();
  cmd.add_option("--stale", c.stale_after_s, "seconds without input before a stale event")
      ->capture_default_str();
}

void ValidateCompareOptions(const compare::CompareNodeConfig& c) {
  Require(std::isfinite(c.publish_rate_hz) && c.publish_rate_hz > 0, "--compare-rate", "> 0 Hz",
          c.publish_rate_hz);
  Require(std::isfinite(c.comparator.window_s) && c.comparator.window_s > 0, "--window", "> 0 s",
          c.comparator.window_s);
  Require(std::isfinite(c.stale_after_s) && c.stale_after_s > 0, "--stale", "> 0 s",
          c.stale_after_s);
}

}  // namespace rocklab::tools
