// rocklab LCM logs: raw_frame_t events on RL_RAW, decoded with the channel
// names of the first RL_DAQ_CONFIG event in the log. Read in file order by
// common::LogReader; a damaged region is a problem (file, byte offset) and is
// counted in SourceStats::damaged_*.
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/lcm_log.h"
#include "common/versions.h"
#include "common/wire.h"

#include "daq/source.h"
#include "common/text.h"
#include "rocklab/raw_frame_t.hpp"

namespace rocklab::daq {
namespace {

class LcmLogSource final : public Source {
 public:
  LcmLogSource(const std::string& path, const SourceOptions& options)
      : path_(path), raw_channel_(options.raw_channel), on_problem_(options.on_problem) {
    rate_hz_ = options.sample_rate_hz;
    {
      // First pass: the channel description (sent at start and every few
      // seconds, so it may come after the first frames). Damage is reported
      // by the second pass only.
      common::LogReader scan(path);  // throws naming the file
      common::LogEvent ev;
      // daq_config2_t, or daq_config_t from a log written before it.
      rocklab::daq_config2_t config;
      common::DaqConfigDecoder decode;
      while (scan.Next(ev)) {
        if (ev.channel != options.config_channel) continue;
        if (decode(ev.data.data(), static_cast<int>(ev.data.size()), config)) continue;
        names_ = config.channel_names;
        if (config.sample_rate_hz > 0) rate_hz_ = config.sample_rate_hz;
        break;
      }
    }
    if (names_.empty()) names_ = options.fallback_channel_names;
    if (names_.empty()) {
      throw std::runtime_error(path + ": no " + options.config_channel +
                               " event names the channels, and no fallback names were given");
    }
    if (!(rate_hz_ > 0)) throw std::runtime_error(path + ": no sample rate (config or rig)");
    common::LogReaderOptions read;
    read.on_problem = [this](const common::LogProblem& p) {
      stats_.damaged_regions += 1;
      stats_.damaged_bytes += p.bytes;
      stats_.damaged_events += p.events;
      if (on_problem_) {
        on_problem_(Problem{{&path_, p.offset},
                            "damaged LCM log region at byte offset " + std::to_string(p.offset) + " (" +
                                std::to_string(p.bytes) + " bytes, " + std::to_string(p.events) +
                                (p.events == 1 ? " event" : " events") + " skipped): " + p.what});
      }
    };
    log_ = std::make_unique<common::LogReader>(path, std::move(read));
  }

  const std::vector<std::string>& channel_names() const override { return names_; }
  double sample_rate_hz() const override { return rate_hz_; }
  const SourceStats& stats() const override { return stats_; }
  const std::string& path() const override { return path_; }

  ReadStatus Next(Frame& frame) override {
    while (log_->Next(ev_)) {
      if (ev_.channel != raw_channel_) continue;
      ++stats_.rows;
      // Guarded: num_channels is checked against the bytes before decode resizes.
      if (const char* why =
              common::GuardedDecode(ev_.data.data(), static_cast<int>(ev_.data.size()), msg_)) {
        Bad(ev_.number, std::string("RL_RAW event does not decode as raw_frame_t (skipped): ") + why);
        continue;
      }
      if (static_cast<size_t>(msg_.num_channels) != names_.size()) {
        std::ostringstream what;
        what << "raw frame has " << msg_.num_channels << " channels, the config names "
             << names_.size() << " (skipped)";
        Bad(ev_.number, what.str());
        continue;
      }
      frame.seq = msg_.seq;
      frame.time_s = static_cast<double>(msg_.utime) * 1e-6;
      frame.line = ev_.number;
      frame.values.assign(msg_.values.begin(), msg_.values.end());
      return ReadStatus::kFrame;
    }
    return ReadStatus::kEnd;
  }

 private:
  void Bad(int64_t event, const std::string& what) {
    ++stats_.bad_rows;
    if (on_problem_) on_problem_(Problem{{&path_, event}, what});
  }

  std::string path_;
  std::string raw_channel_;
  ProblemCallback on_problem_;
  std::vector<std::string> names_;
  double rate_hz_{};
  std::unique_ptr<common::LogReader> log_;
  common::LogEvent ev_;       // reused: keeps its buffers' capacity
  rocklab::raw_frame_t msg_;  // reused: decode keeps the vector's capacity
  SourceStats stats_;
};

}  // namespace

std::unique_ptr<Source> OpenLcmLogSource(const std::string& path, const SourceOptions& options) {
  return std::make_unique<LcmLogSource>(path, options);
}

namespace {
struct RegisteredForm {
  std::string prefix;
  SourceOpener opener;
};
std::vector<RegisteredForm>& RegisteredForms() {
  static std::vector<RegisteredForm> forms;
  return forms;
}
}  // namespace

void RegisterSourceForm(const std::string& prefix, SourceOpener opener) {
  for (RegisteredForm& f : RegisteredForms()) {
    if (f.prefix == prefix) {
      f.opener = opener;
      return;
    }
  }
  RegisteredForms().push_back({prefix, opener});
}

std::unique_ptr<Source> OpenSource(const std::string& path, const SourceOptions& options) {
  for (const RegisteredForm& f : RegisteredForms()) {
    if (path.rfind(f.prefix, 0) == 0) return f.opener(path.substr(f.prefix.size()), options);
  }
  if (path.rfind("video:", 0) == 0 || path.rfind("v4l2:", 0) == 0) {
    throw std::invalid_argument(path + ": this rocklab was built without video inputs "
                                       "(ROCKLAB_VIDEO; needs libopencv-dev and libopencv-contrib-dev)");
  }
  if (path.rfind("tcp://", 0) == 0) return OpenTcpSource(path.substr(6), options);
  if (path.rfind("tcp-listen://", 0) == 0) return OpenTcpSource(path.substr(13), options, true);
  if (path.rfind("lcm://", 0) == 0) return OpenLcmLiveSource(path.substr(6), options);
  if (options.follow && !common::HasExtension(path, ".csv") && !common::HasExtension(path, ".lvm")) {
    throw std::invalid_argument(path + ": --follow reads .csv and .lvm files");
  }
  if (common::HasExtension(path, ".csv")) return OpenCsvSource(path, options);
  if (common::HasExtension(path, ".lvm")) return OpenLvmSource(path, options);
  return OpenLcmLogSource(path, options);
}

std::string ToString(const Problem& problem) {
  std::ostringstream s;
  s << (problem.where.file != nullptr ? *problem.where.file : std::string("?")) << ":"
    << problem.where.line << ": " << problem.message;
  return s.str();
}

int64_t Frame::utime() const { return std::llround(time_s * 1e6); }

}  // namespace rocklab::daq
