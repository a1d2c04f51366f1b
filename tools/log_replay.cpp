#include "tools/log_replay.h"

#include <chrono>
#include <cmath>
#include <regex>
#include <stdexcept>
#include <thread>

namespace rocklab::tools {

void ReplayOptions::Validate() const {
  if (!(speed > 0) || !std::isfinite(speed)) throw std::invalid_argument("--speed must be > 0");
  if (!(start_s >= 0) || !std::isfinite(start_s)) throw std::invalid_argument("--start must be >= 0 s");
  if (end_s >= 0 && end_s <= start_s) throw std::invalid_argument("--end must be after --start");
  try {
    std::regex re(channels);
  } catch (const std::regex_error& e) {
    throw std::invalid_argument("--channels: bad regular expression '" + channels + "': " + e.what());
  }
}

ReplayCounts ReplayLog(const std::string& log_path, const ReplayOptions& o, lcm::LCM& lcm,
                       const std::atomic<bool>& stop) {
  o.Validate();
  const std::regex filter(o.channels);
  ReplayCounts counts;
  std::map<std::string, bool> matches;  // channel -> passes the filter (regex once per channel)

  lcm::LogFile log(log_path, "r");
  if (!log.good()) throw std::runtime_error("cannot read LCM log '" + log_path + "'");
  const lcm::LogEvent* first = log.readNextEvent();
  if (!first) throw std::runtime_error("LCM log '" + log_path + "' has no events");
  const std::int64_t log_t0 = first->timestamp;
  const std::int64_t window_start = log_t0 + static_cast<std::int64_t>(std::llround(o.start_s * 1e6));
  const std::int64_t window_end =
      o.end_s < 0 ? INT64_MAX : log_t0 + static_cast<std::int64_t>(std::llround(o.end_s * 1e6));

  using Clock = std::chrono::steady_clock;
  while (!stop.load()) {
    ++counts.passes;
    if (counts.passes > 1 || o.start_s > 0) {
      // seekToTimestamp lands near the time: skip what is before the window.
      if (log.seekToTimestamp(window_start) != 0 && log.seekToTimestamp(log_t0) != 0) {
        throw std::runtime_error("cannot seek in LCM log '" + log_path + "'");
      }
    } else if (log.seekToTimestamp(log_t0) != 0) {
      throw std::runtime_error("cannot seek in LCM log '" + log_path + "'");
    }
    const Clock::time_point wall0 = Clock::now();
    bool any = false;
    while (!stop.load()) {
      const lcm::LogEvent* ev = log.readNextEvent();
      if (!ev || ev->timestamp > window_end) break;
      if (ev->timestamp < window_start) continue;
      any = true;
      ++counts.read;
      auto it = matches.find(ev->channel);
      if (it == matches.end()) {
        it = matches.emplace(ev->channel, std::regex_match(ev->channel, filter)).first;
      }
      if (!it->second) {
        ++counts.filtered;
        continue;
      }
      if (!o.max_speed) {
        const double due_s = static_cast<double>(ev->timestamp - window_start) * 1e-6 / o.speed;
        const auto due = wall0 + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(due_s));
        // Sleep in slices so a stop request is honoured within 50 ms.
        while (!stop.load() && Clock::now() < due) {
          std::this_thread::sleep_until(std::min(due, Clock::now() + std::chrono::milliseconds(50)));
        }
        if (stop.load()) break;
      }
      if (lcm.publish(ev->channel, ev->data, static_cast<unsigned>(ev->datalen)) == 0) {
        ++counts.published;
        ++counts.per_channel[ev->channel];
      } else {
        ++counts.failed;
      }
    }
    if (!o.loop || !any) break;
  }
  return counts;
}

}  // namespace rocklab::tools
