// lcm://CHANNEL: raw_frame_t messages published by an acquisition program
// (C, C++, Java, MATLAB through LCM's Java binding) on CHANNEL of an LCM URL.
// Its own lcm::LCM, handled on the reading thread inside Next(): no thread,
// no queue of ours; LCM's subscription queue is raised to 4096 messages (4 s
// at 1 kHz) so a slow publish downstream does not drop samples, and what LCM
// still drops shows as a sequence gap (counted by the DAQ's sequence checker).
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

#include "common/bus_urls.h"
#include "common/wire.h"
#include "daq/line_input.h"
#include "daq/source.h"
#include "rocklab/raw_frame_t.hpp"

namespace rocklab::daq {
namespace {

using Clock = std::chrono::steady_clock;

class LcmLiveSource final : public Source {
 public:
  LcmLiveSource(const std::string& channel, const SourceOptions& options)
      : path_("lcm://" + channel),
        names_(options.fallback_channel_names),
        rate_hz_(options.sample_rate_hz),
        idle_timeout_s_(options.idle_timeout_s),
        stop_(options.stop),
        on_problem_(options.on_problem),
        lcm_(options.lcm_url) {
    if (channel.empty()) throw std::invalid_argument("lcm://: no channel (expected lcm://CHANNEL)");
    if (channel == options.raw_channel) {
      throw std::invalid_argument(path_ + ": the DAQ republishes its frames on " + options.raw_channel +
                                  "; the acquisition program must publish on another channel");
    }
    if (names_.empty()) throw std::invalid_argument(path_ + ": no channel names (the rig's [[channel]] entries)");
    if (!(rate_hz_ > 0)) throw std::invalid_argument(path_ + ": no sample rate (the rig's sample_rate_hz)");
    if (!lcm_.good()) throw std::runtime_error(path_ + ": cannot open LCM at '" + options.lcm_url + "'");
    // Exact channel, not a regex: a name with '.' or '+' means itself.
    lcm::Subscription* sub =
        lcm_.subscribeFunction(common::ExactChannelRegex(channel), &LcmLiveSource::OnMessage, this);
    sub->setQueueCapacity(4096);
    last_data_ = Clock::now();
  }

  const std::vector<std::string>& channel_names() const override { return names_; }
  double sample_rate_hz() const override { return rate_hz_; }
  const SourceStats& stats() const override { return stats_; }
  const std::string& path() const override { return path_; }
  bool live() const override { return true; }

  ReadStatus Next(Frame& frame) override {
    if (!error_.empty()) return ReadStatus::kError;
    out_ = &frame;
    got_ = false;
    const auto slice_end = Clock::now() + std::chrono::milliseconds(detail::kIdleSliceMs);
    while (!got_) {
      if (stop_ && stop_->load()) return ReadStatus::kEnd;
      const auto now = Clock::now();
      if (idle_timeout_s_ > 0 && std::chrono::duration<double>(now - last_data_).count() > idle_timeout_s_) {
        return ReadStatus::kEnd;
      }
      if (now >= slice_end) return ReadStatus::kIdle;
      const int wait_ms = static_cast<int>(
          std::chrono::duration_cast<std::chrono::milliseconds>(slice_end - now).count()) + 1;
      if (lcm_.handleTimeout(wait_ms) < 0) {
        // A signal interrupts the wait: the stop (checked above on the next
        // pass), or another signal; anything else is a failed receive.
        if (errno == EINTR) continue;
        error_ = path_ + ": LCM receive failed (" + std::strerror(errno) + ")";
        if (on_problem_) on_problem_(Problem{{&path_, stats_.rows}, error_.substr(path_.size() + 2)});
        return ReadStatus::kError;
      }
    }
    return ReadStatus::kFrame;
  }

 private:
  static void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string&, LcmLiveSource* self) {
    self->Handle(rbuf);
  }

  // On the reading thread, inside handleTimeout; never throws (GuardedDecode).
  void Handle(const lcm::ReceiveBuffer* rbuf) {
    ++stats_.rows;
    last_data_ = Clock::now();
    if (const char* why = common::GuardedDecode(rbuf->data, static_cast<int>(rbuf->data_size), msg_)) {
      Bad(std::string("message does not decode as raw_frame_t (skipped): ") + why);
      return;
    }
    if (static_cast<size_t>(msg_.num_channels) != names_.size()) {
      std::ostringstream what;
      what << "raw frame has " << msg_.num_channels << " values, the rig names " << names_.size()
           << " channels (skipped)";
      Bad(what.str());
      return;
    }
    if (got_) {  // handleTimeout dispatches one message; kept safe anyway
      ++stats_.bad_rows;
      return;
    }
    out_->seq = msg_.seq;
    out_->time_s = static_cast<double>(msg_.utime) * 1e-6;
    out_->line = stats_.rows;
    out_->comment.clear();
    out_->values.assign(msg_.values.begin(), msg_.values.end());
    got_ = true;
  }

  void Bad(const std::string& what) {
    ++stats_.bad_rows;
    if (on_problem_) on_problem_(Problem{{&path_, stats_.rows}, what});
  }

  std::string path_;
  std::vector<std::string> names_;
  double rate_hz_{};
  double idle_timeout_s_{};
  const std::atomic<bool>* stop_{};  // not owned
  ProblemCallback on_problem_;
  lcm::LCM lcm_;
  rocklab::raw_frame_t msg_;  // reused
  Frame* out_{};              // the frame Next is filling
  bool got_{false};
  Clock::time_point last_data_;
  SourceStats stats_;
};

}  // namespace

std::unique_ptr<Source> OpenLcmLiveSource(const std::string& channel, const SourceOptions& options) {
  return std::make_unique<LcmLiveSource>(channel, options);
}

}  // namespace rocklab::daq
