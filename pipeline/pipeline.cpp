#include "pipeline/pipeline.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "model/block.h"

namespace rocklab::pipeline {

std::unique_ptr<common::LcmBus> OpenLcmBus(const std::string& url) {
  try {
    return std::make_unique<common::LcmBus>(url);
  } catch (const std::runtime_error&) {
    throw OptionError("--lcm-url: cannot open LCM at '" + url + "'");
  }
}

daq::RigConfig LoadRig(const std::string& path) {
  try {
    return daq::LoadRigConfig(path);
  } catch (const std::exception& e) {
    throw OptionError(std::string("--rig: ") + e.what());
  }
}

model::BlockParams TheoreticalParams(const daq::RigConfig& rig) {
  if (rig.block.polygon_m.empty()) {
    return model::RectangleBlock(rig.block.width_m, rig.block.height_m, rig.block.chamfer_m).params();
  }
  std::vector<Eigen::Vector2d> vertices;
  for (const auto& xz : rig.block.polygon_m) vertices.emplace_back(xz[0], xz[1]);
  try {
    return model::PolygonBlock(vertices).params();
  } catch (const std::invalid_argument& e) {
    throw OptionError(rig.path + ":" + std::to_string(rig.block.polygon_line) + ": key 'block.polygon' " +
                         std::string(e.what()).substr(std::string(e.what()).rfind("vertices_m: ", 0) == 0 ? 12 : 0));
  }
}

daq::DaqNodeConfig DaqConfigFor(const daq::RigConfig& rig, const std::string& input, double speed) {
  daq::DaqNodeConfig config;
  config.rig = rig;
  const model::BlockParams theory = TheoreticalParams(rig);
  if (!config.rig.block.alpha) config.rig.block.alpha = theory.alpha;
  if (!config.rig.block.p) config.rig.block.p = theory.p;
  if (!config.rig.block.mu) config.rig.block.mu = theory.mu;
  config.input = input;
  config.speed = speed;
  return config;
}

int ReportDamage(long long regions, long long bytes, long long events, const std::string& input,
                 const char* what, const char* rest) {
  if (regions <= 0) return 0;
  std::fprintf(stderr, "%s: %s is damaged: %lld region%s skipped (%lld bytes, %lld events lost)%s\n",
               what, input.c_str(), regions, regions == 1 ? "" : "s", bytes, events, rest);
  return 1;  // the command failed (tools::kFailureExit)
}

int ReportDamage(const daq::DaqNodeStats& s, const std::string& input, const char* what) {
  if (!s.read_error.empty()) {
    std::fprintf(stderr, "%s: %s\n", what, s.read_error.c_str());  // names the file
  }
  const int damaged = ReportDamage(s.damaged_regions, s.damaged_bytes, s.damaged_events, input, what,
                                   "; the rest was read");
  return s.read_error.empty() ? damaged : 1;
}

int RunDaqStage(const DaqStageOptions& o, const char* what, const std::atomic<bool>& stop) {
  Require(std::isfinite(o.speed) && o.speed > 0, "--speed", "> 0", o.speed);
  daq::DaqNodeConfig config = DaqConfigFor(LoadRig(o.rig_path), o.input, o.max_speed ? 0.0 : o.speed);
  config.prefix = o.prefix;
  const std::unique_ptr<common::LcmBus> bus = OpenLcmBus(o.lcm_url);
  std::unique_ptr<daq::DaqNode> node;
  try {
    node = std::make_unique<daq::DaqNode>(config, *bus);
  } catch (const std::exception& e) {
    throw OptionError(e.what());  // names the input file (and line) or the LCM URL
  }
  node->Run(stop);
  const daq::DaqNodeStats& s = node->stats();
  std::fprintf(stderr,
               "%s: %lld frames read, %lld messages published (%lld failed), %lld gaps "
               "(%lld samples missing), %lld bad samples%s\n",
               what, static_cast<long long>(s.frames_read), static_cast<long long>(s.published),
               static_cast<long long>(s.publish_errors), static_cast<long long>(s.gaps),
               static_cast<long long>(s.missing), static_cast<long long>(s.bad_samples),
               s.stopped_early ? ", stopped by signal" : "");
  return ReportDamage(s, o.input, what);
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
      throw OptionError(std::string("--variant: ") + e.what());
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (out[i].name == out[j].name) {
        throw OptionError("--variant: name '" + out[i].name + "' used twice");
      }
    }
  }
  return out;
}

void ValidateCompareOptions(const compare::CompareNodeConfig& c) {
  Require(std::isfinite(c.publish_rate_hz) && c.publish_rate_hz > 0, "--compare-rate", "> 0 Hz",
          c.publish_rate_hz);
  Require(std::isfinite(c.comparator.window_s) && c.comparator.window_s > 0, "--window", "> 0 s",
          c.comparator.window_s);
  Require(std::isfinite(c.stale_after_s) && c.stale_after_s > 0, "--stale", "> 0 s",
          c.stale_after_s);
}

}  // namespace rocklab::pipeline
