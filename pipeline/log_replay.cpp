#include "pipeline/log_replay.h"

#include <cmath>
#include <regex>
#include <stdexcept>

#include "common/channel_pattern.h"
#include "common/lcm_log.h"
#include "common/text.h"
#include "daq/pacer.h"

namespace rocklab::pipeline {

void ReplayOptions::Validate() const {
  if (!(speed > 0) || !std::isfinite(speed)) throw std::invalid_argument("--speed must be > 0");
  if (!(start_s >= 0) || !std::isfinite(start_s)) throw std::invalid_argument("--start must be >= 0 s");
  if (!(end_s >= 0)) {
    throw std::invalid_argument("--end must be >= 0 s (leave it out to replay to the end), got " +
                                common::Format("%g", end_s));
  }
  if (end_s <= start_s) throw std::invalid_argument("--end must be after --start");
  common::ChannelPattern(channels, "--channels");
}

ReplayCounts ReplayLog(const std::string& log_path, const ReplayOptions& o, common::Bus& bus,
                       const std::atomic<bool>& stop,
                       const std::function<void(const std::string&)>& on_problem) {
  o.Validate();
  common::LogReaderOptions read;
  read.channels = o.channels;
  read.start_s = o.start_s;
  read.end_s = std::isinf(o.end_s) ? -1.0 : o.end_s;  // the reader's "no end"
  if (on_problem) read.on_problem = [&on_problem](const common::LogProblem& p) { on_problem(ToString(p)); };
  common::LogReader log(log_path, read);  // throws naming the file
  const std::int64_t window_start =
      log.first_timestamp_us() + static_cast<std::int64_t>(std::llround(o.start_s * 1e6));

  ReplayCounts counts;
  common::LogEvent ev;
  // An event stamped before the window's start or an earlier event (logs
  // whose stamps go back) is due at once; a stop is honoured within 20 ms.
  daq::Pacer pacer(o.max_speed ? 0.0 : o.speed);
  while (!stop.load()) {
    ++counts.passes;
    if (counts.passes > 1) log.Rewind();
    pacer.Restart(0.0);  // the window's start is due now, on every pass
    bool any = false;
    while (!stop.load() && log.Next(ev)) {
      any = true;
      if (!pacer.WaitFor(static_cast<double>(ev.timestamp_us - window_start) * 1e-6, stop)) break;
      if (bus.Publish(ev.channel, ev.data.data(), static_cast<int>(ev.data.size()))) {
        ++counts.published;
        ++counts.per_channel[ev.channel];
      } else {
        ++counts.failed;
      }
    }
    if (!o.loop || !any) break;
  }
  const common::LogReadCounts& n = log.counts();
  counts.read = n.delivered + n.filtered;
  counts.filtered = n.filtered;
  counts.damaged_regions = n.damaged_regions;
  counts.damaged_bytes = n.damaged_bytes;
  counts.damaged_events = n.damaged_events;
  return counts;
}

}  // namespace rocklab::pipeline
