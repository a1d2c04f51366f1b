#include "pipeline/pipeline.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/bus_urls.h"
#include "common/lcm_bus.h"
#include "common/routing_bus.h"
#include "common/sd_notify.h"
#include "common/text.h"
#include "daq/source.h"
#include "model/block.h"
#include "pipeline/assembly.h"
#include "record/log_provenance.h"
#include "record/log_writer.h"
#include "rocklab/health2_t.hpp"

namespace rocklab::pipeline {

std::unique_ptr<common::LcmBus> OpenLcmBus(const std::string& url) {
  try {
    return std::make_unique<common::LcmBus>(url);
  } catch (const std::runtime_error&) {
    throw OptionError("--lcm-url: cannot open LCM at '" + url + "'");
  }
}

std::unique_ptr<common::LcmBus> OpenRawBus(const std::string& lcm_url, const std::string& raw_url) {
  std::string url;
  try {
    url = common::RawUrl(lcm_url, raw_url);
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());  // starts with "--raw-url: "
  }
  if (url.empty()) return nullptr;
  try {
    return std::make_unique<common::LcmBus>(url);
  } catch (const std::runtime_error&) {
    throw OptionError("--raw-url: cannot open LCM at '" + url + "'");
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

namespace {

char DelimiterOf(const std::string& text) {
  if (text.empty()) return 0;
  if (text == "," || text == "comma") return ',';
  if (text == ";" || text == "semicolon") return ';';
  if (text == "\t" || text == "tab" || text == "\\t") return '\t';
  throw OptionError("--delimiter: '" + text + "' is not ',', ';' or tab");
}

// Checks the options and builds the node's configuration (the rig loaded).
daq::DaqNodeConfig StageConfig(const DaqStageOptions& o, const std::atomic<bool>* stop) {
  Require(std::isfinite(o.speed) && o.speed > 0, "--speed", "> 0", o.speed);
  Require(std::isfinite(o.idle_timeout_s) && o.idle_timeout_s >= 0, "--idle-timeout", ">= 0 s (0 = never)",
          o.idle_timeout_s);
  Require(o.rotate_bytes >= 0, "--rotate-size", ">= 0 bytes", static_cast<double>(o.rotate_bytes));
  Require(std::isfinite(o.rotate_seconds) && o.rotate_seconds >= 0, "--rotate-seconds", ">= 0 s",
          o.rotate_seconds);
  if ((o.rotate_bytes > 0 || o.rotate_seconds > 0) && o.log_path.empty()) {
    throw OptionError("--rotate-size/--rotate-seconds: rotate what? give --log FILE");
  }
  if (o.rig_path.empty()) throw OptionError("--rig: required (on the command line or as 'rig' in --config)");
  if (o.input.empty()) throw OptionError("--input: required (on the command line or as 'input' in --config)");
  const bool live_url = o.input.rfind("tcp://", 0) == 0 || o.input.rfind("tcp-listen://", 0) == 0 ||
                        o.input.rfind("lcm://", 0) == 0;
  if (o.follow && (live_url || !(common::HasExtension(o.input, ".csv") || common::HasExtension(o.input, ".lvm")))) {
    throw OptionError("--follow: follows a .csv or .lvm file, not '" + o.input + "'");
  }
  daq::DaqNodeConfig config = DaqConfigFor(LoadRig(o.rig_path), o.input, o.max_speed ? 0.0 : o.speed);
  config.prefix = o.prefix;
  config.delimiter = DelimiterOf(o.delimiter);
  config.follow = o.follow;
  config.idle_timeout_s = o.idle_timeout_s;
  config.lcm_url = o.lcm_url;
  config.stop = stop;
  return config;
}

// Writes every message the DAQ publishes to a rotated LCM log series
// (record::RotatingLogWriter, the recorder's rotation: each event in exactly
// one file, event numbers continuing across files), then publishes it.
class RotatingLogBus final : public common::Bus {
 public:
  RotatingLogBus(common::Bus& inner, record::RotatingLogWriter& log)
      : Bus(SharesCountersWith{inner}), inner_(inner), log_(log) {}
  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override {
    bool logged = false;
    const int64_t utime = common::PayloadUtime(data, size, last_utime_);
    if (WaitingHeartbeat(channel, data, size, utime)) {
      // Sent while the input waits for its header: no sample time (utime
      // 0). It goes out live now, and into the log just before the first
      // message with a time, stamped with that time (a log opening at 0
      // before an epoch-based sample clock would make a 1x replay wait for
      // decades), or at the stop when none came (FlushWaiting).
      if (waiting_.size() < kMaxWaiting) {
        waiting_.push_back({channel, std::vector<uint8_t>(static_cast<const uint8_t*>(data),
                                                          static_cast<const uint8_t*>(data) + size)});
      } else {
        ++waiting_dropped_;
      }
      return inner_.Publish(channel, data, size);
    }
    if (size >= 0) {
      FlushWaiting(utime);
      logged = log_.Write(utime, channel, static_cast<const uint8_t*>(data), static_cast<uint32_t>(size));
      last_utime_ = utime;
    }
    if (!logged) ++log_errors_;
    return inner_.Publish(channel, data, size) && logged;
  }
  common::Subscription SubscribeRaw(const std::string& regex, RawHandler handler, int queue) override {
    return inner_.SubscribeRaw(regex, std::move(handler), queue);
  }
  int HandleTimeout(int timeout_ms) override { return inner_.HandleTimeout(timeout_ms); }
  int64_t log_errors() const { return log_errors_; }
  /// Heartbeats sent while waiting for the header and not logged: over
  /// kMaxWaiting before the first message with a time.
  int64_t waiting_dropped() const { return waiting_dropped_; }

  /// Writes the kept "waiting for header" heartbeats stamped `utime`
  /// (the first time in the log, or at the stop the last one, else 0).
  void FlushWaiting(int64_t utime) {
    for (const Waiting& w : waiting_) {
      if (!log_.Write(utime, w.channel, w.data.data(), static_cast<uint32_t>(w.data.size()))) ++log_errors_;
    }
    waiting_.clear();
  }
  void FlushWaiting() { FlushWaiting(last_utime_); }

 private:
  // One heartbeat a health period (1 s by default): 4096 is over an hour of
  // waiting, ~0.5 MB.
  static constexpr std::size_t kMaxWaiting = 4096;
  struct Waiting {
    std::string channel;
    std::vector<uint8_t> data;
  };
  // The DAQ node's RL_HEALTH while its input waits for a header.
  static bool WaitingHeartbeat(const std::string& channel, const void* data, int size, int64_t utime) {
    static const std::string kHealth = "HEALTH";
    if (utime != 0 || size < 0 || channel.size() < kHealth.size() ||
        channel.compare(channel.size() - kHealth.size(), kHealth.size(), kHealth) != 0) {
      return false;
    }
    rocklab::health2_t m;
    return m.decode(data, 0, size) >= 0 && m.state == "waiting for header";
  }

  common::Bus& inner_;             // not owned
  record::RotatingLogWriter& log_;  // not owned
  int64_t last_utime_{0};
  int64_t log_errors_{0};
  std::vector<Waiting> waiting_;  // not yet logged, oldest first
  int64_t waiting_dropped_{0};
};

}  // namespace

int RunDaqStage(const DaqStageOptions& o, const char* what, const std::atomic<bool>& stop) {
  daq::DaqNodeConfig config = StageConfig(o, &stop);
  const std::unique_ptr<common::LcmBus> lcm_bus = OpenLcmBus(o.lcm_url);
  // <prefix>RAW on its own bus (common/bus_urls.h), everything else on lcm_url.
  const std::unique_ptr<common::LcmBus> raw_bus = OpenRawBus(o.lcm_url, o.raw_url);
  std::unique_ptr<common::RoutingBus> routing;
  common::Bus* bus = lcm_bus.get();
  if (raw_bus) {
    routing = std::make_unique<common::RoutingBus>(*lcm_bus, *raw_bus, common::ExactChannelRegex(common::RawChannel(o.prefix)));
    bus = routing.get();
  }
  std::unique_ptr<record::LogProvenance> provenance;  // before the log: it outlives the writer
  std::unique_ptr<record::RotatingLogWriter> log;
  std::unique_ptr<RotatingLogBus> log_bus;
  if (!o.log_path.empty()) {
    record::RotationOptions rotation;
    rotation.path = o.log_path;
    rotation.rotate_bytes = o.rotate_bytes;
    rotation.rotate_seconds = o.rotate_seconds;
    rotation.overwrite = true;
    // Each finished file's provenance beside it (record/log_provenance.h),
    // as run's log has it; the rig and input hashed on a thread of their
    // own. A followed input grows while it is read: named, not hashed.
    const daq::RigConfig& rig = config.rig;
    record::LogProvenance::Fields extra = {
        {"rig", rig.name + (rig.calibration_id.empty() ? "" : ", calibration " + rig.calibration_id)}};
    std::vector<std::string> sources = {o.rig_path};
    if (o.follow) {
      extra.emplace_back("followed_input", o.input + " (followed as it grew: not hashed)");
    } else {
      sources.push_back(o.input);
    }
    provenance = std::make_unique<record::LogProvenance>(sources, extra);
    provenance->Attach(rotation);
    try {
      log = std::make_unique<record::RotatingLogWriter>(rotation);
    } catch (const std::exception& e) {
      throw OptionError(std::string("--log: ") + e.what());
    }
    log_bus = std::make_unique<RotatingLogBus>(*bus, *log);  // every channel, RL_RAW too
    bus = log_bus.get();
  }
  // The log's summary and closing, also when stopped before the header.
  const auto close_log = [&]() {
    if (!log) return 0;
    log_bus->FlushWaiting();
    const bool closed = log->Close();
    std::fprintf(stderr, "%s: --log: %lld events in %zu file%s%s\n", what, static_cast<long long>(log->events()),
                 log->files().size(), log->files().size() == 1 ? "" : "s",
                 log_bus->log_errors() > 0 || !closed ? " (write errors: see above)" : "");
    if (log_bus->waiting_dropped() > 0) {
      std::fprintf(stderr, "%s: --log: %lld \"waiting for header\" heartbeats not logged (over the first 4096)\n",
                   what, static_cast<long long>(log_bus->waiting_dropped()));
    }
    int failed = 0;
    if (provenance->errors() > 0) {
      std::fprintf(stderr, "%s: --log: %lld provenance sidecars could not be written (see above)\n", what,
                   static_cast<long long>(provenance->errors()));
      failed = 1;
    }
    if (log_bus->log_errors() > 0 || !closed) {
      std::fprintf(stderr, "%s: --log: %lld events could not be written: %s\n", what,
                   static_cast<long long>(log_bus->log_errors()), log->error().c_str());
      failed = 1;
    }
    return failed;
  };
  std::unique_ptr<daq::DaqNode> node;
  try {
    node = std::make_unique<daq::DaqNode>(config, *bus);
  } catch (const std::exception& e) {
    if (stop.load()) {  // SIGINT/SIGTERM while a live input's header was awaited: a stop, not an error
      common::NotifySystemd("STOPPING=1");  // as a node that ran says at its stop
      std::fprintf(stderr, "%s: stopped by signal before %s sent its header\n", what,
                   common::Printable(o.input).c_str());
      return close_log();
    }
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
  if (s.restarts > 0 || s.comments > 0) {
    std::fprintf(stderr, "%s: %lld input restarts (%lld samples lost across them), %lld comments\n", what,
                 static_cast<long long>(s.restarts), static_cast<long long>(s.restart_lost),
                 static_cast<long long>(s.comments));
  }
  if (o.stats_out != nullptr) *o.stats_out = s;
  int code = ReportDamage(s, o.input, what);
  if (close_log() != 0) code = 1;
  return code;
}

void CheckDaqStage(const DaqStageOptions& o) {
  const daq::DaqNodeConfig config = StageConfig(o, nullptr);
  const daq::RigConfig& rig = config.rig;
  std::printf("rig: %s (%s), %zu channels, sample rate %g Hz\n", rig.path.c_str(), rig.name.c_str(),
              rig.channels.size(), rig.sample_rate_hz);
  if (o.input.rfind("tcp://", 0) == 0) {
    std::printf("input: TCP stream from %s (CSV lines, header first; reconnects with backoff)\n",
                o.input.c_str() + 6);
  } else if (o.input.rfind("tcp-listen://", 0) == 0) {
    std::printf("input: TCP stream, listening on %s for the acquisition PC (CSV lines, header first)\n",
                o.input.c_str() + 13);
  } else if (o.input.rfind("lcm://", 0) == 0) {
    const std::string channel = o.input.substr(6);
    if (channel.empty() || channel == o.prefix + "RAW") {
      throw OptionError("--input: lcm://CHANNEL must name a channel other than " + o.prefix + "RAW");
    }
    std::printf("input: raw_frame_t on LCM channel %s of %s, values in the rig's channel order\n",
                channel.c_str(), o.lcm_url.empty() ? "LCM's default URL" : o.lcm_url.c_str());
  } else {
    daq::SourceOptions so;
    so.sample_rate_hz = rig.sample_rate_hz;
    so.raw_channel = o.prefix + "RAW";
    so.config_channel = o.prefix + "DAQ_CONFIG";
    so.delimiter = config.delimiter;
    so.rig = &rig;
    for (const auto& c : rig.channels) so.fallback_channel_names.push_back(c.name);
    std::unique_ptr<daq::Source> source;
    try {
      source = daq::OpenSource(o.input, so);  // not followed: the header is what is checked
    } catch (const std::exception& e) {
      throw OptionError(std::string("--input: ") + e.what());
    }
    std::printf("input: %s%s, sample rate %g Hz, channels:", o.input.c_str(), o.follow ? " (followed)" : "",
                source->sample_rate_hz());
    for (const auto& n : source->channel_names()) std::printf(" %s", n.c_str());
    std::printf("\n");
    for (const auto& c : rig.channels) {
      bool found = false;
      for (const auto& n : source->channel_names()) found = found || n == c.name;
      if (!found) throw OptionError("--input: " + o.input + " has no column '" + c.name + "' the rig names");
    }
  }
  std::string raw_url;
  try {
    raw_url = common::RawUrl(o.lcm_url, o.raw_url);
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());  // starts with "--raw-url: "
  }
  const std::string main_url = o.lcm_url.empty() ? "LCM's default URL (" + common::ResolveLcmUrl("") + ")" : o.lcm_url;
  if (raw_url.empty()) {
    std::printf("publish: %sDAQ_CONFIG %sRAW %sTHETA %sTABLE %sEVENT %sHEALTH on %s\n", o.prefix.c_str(),
                o.prefix.c_str(), o.prefix.c_str(), o.prefix.c_str(), o.prefix.c_str(), o.prefix.c_str(),
                main_url.c_str());
  } else {
    std::printf("publish: %sDAQ_CONFIG %sTHETA %sTABLE %sEVENT %sHEALTH on %s; %sRAW on %s\n", o.prefix.c_str(),
                o.prefix.c_str(), o.prefix.c_str(), o.prefix.c_str(), o.prefix.c_str(), main_url.c_str(),
                o.prefix.c_str(), raw_url.c_str());
  }
  if (!o.log_path.empty()) {
    std::printf("log: %s", o.log_path.c_str());
    if (o.rotate_bytes > 0) std::printf(", a new file every %lld bytes", static_cast<long long>(o.rotate_bytes));
    if (o.rotate_seconds > 0) std::printf(", a new file every %g s", o.rotate_seconds);
    std::printf("\n");
  }
  if (o.idle_timeout_s > 0) std::printf("idle timeout: %g s\n", o.idle_timeout_s);
  std::printf("ok\n");
}

std::vector<model::VariantSpec> BuildVariants(const std::vector<std::string>& texts, const daq::RigConfig& rig,
                                              double rtol) {
  Require(rtol > 0.0 && rtol <= 1e-3, "--rtol", "in (0, 1e-3]", rtol);
  const model::BlockParams theory = TheoreticalParams(rig);
  std::vector<std::string> specs = texts;
  if (specs.empty()) specs = {"housner:housner:theoretical", "complex:complex:theoretical"};
  std::vector<model::VariantSpec> out;
  for (const std::string& s : specs) {
    try {
      out.push_back(model::ParseVariant(s, theory));
      out.back().options.rtol = rtol;
    } catch (const std::invalid_argument& e) {
      throw OptionError(std::string("--variant: ") + e.what());
    }
    if (!out.back().assembly_path.empty()) {
      try {
        ResolveAssemblyVariant(out.back());  // its file's errors name it, line and key
      } catch (const OptionError& e) {
        std::string why = e.what();  // "--assembly: FILE:LINE: ..." as simulate --assembly says it
        if (why.rfind("--assembly: ", 0) == 0) why.erase(0, std::string("--assembly: ").size());
        throw OptionError("--variant '" + s + "': " + why);
      }
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

void PrintVariants(const std::vector<model::VariantSpec>& variants, std::FILE* out) {
  for (const model::VariantSpec& v : variants) {
    if (v.stack) {
      std::fprintf(out, "variant %s: %s, a stack of %d bodies, per-body model_state4_t (%s)\n", v.name.c_str(),
                   model::ToString(v.kind), v.stack->bodies(), v.params_source.c_str());
      continue;
    }
    std::fprintf(out, "variant %s: %s, alpha %.4f rad, p %.4f rad/s, mu %.4f (%s)\n", v.name.c_str(),
                 model::ToString(v.kind), v.params.alpha, v.params.p, v.params.mu, v.params_source.c_str());
  }
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
