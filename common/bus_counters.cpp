#include "common/bus_counters.h"

#include <exception>
#include <memory>

#include <spdlog/spdlog.h>

#include "common/logger_clock.h"

namespace rocklab::common {
namespace {

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> log = NamedLogger("bus");
  return log;
}

std::int64_t Sum(const std::map<std::string, std::int64_t>& counts) {
  std::int64_t n = 0;
  for (const auto& [channel, count] : counts) n += count;
  return n;
}

}  // namespace

std::int64_t BusCounters::decode_error_count() const { return Sum(decode_errors_); }
std::int64_t BusCounters::handler_error_count() const { return Sum(handler_errors_); }

void BusCounters::Warn(std::map<std::string, double>& last, const std::string& channel,
                       const std::string& what) {
  // At most one line a second per channel; the counters hold the rest.
  const double now = HostNowS();
  auto it = last.find(channel);
  if (it != last.end() && now - it->second < 1.0) return;
  last[channel] = now;
  Log()->warn("{}", what);
}

void BusCounters::CountDecodeError(const std::string& channel, const char* why) {
  const std::int64_t n = ++decode_errors_[channel];
  Warn(last_decode_warning_s_, channel,
       "channel " + channel + ": a message does not decode (" + why + "): dropped (" +
           std::to_string(n) + " so far)");
}

template <class Call>
void BusCounters::Guarded(const std::string& channel, Call&& call) {
  try {
    call();
  } catch (const std::exception& e) {
    const std::int64_t n = ++handler_errors_[channel];
    Warn(last_handler_warning_s_, channel,
         "channel " + channel + ": handler failed: " + e.what() + " (" + std::to_string(n) +
             " so far)");
  } catch (...) {
    const std::int64_t n = ++handler_errors_[channel];
    Warn(last_handler_warning_s_, channel,
         "channel " + channel + ": handler failed (" + std::to_string(n) + " so far)");
  }
}

void BusCounters::Dispatch(const std::function<void(const std::string&, const void*, int)>& handler,
                           const std::string& channel, const void* data, int size) {
  Guarded(channel, [&] { handler(channel, data, size); });
}

void BusCounters::DispatchValue(const std::function<void(const std::string&, const void*)>& handler,
                                const std::string& channel, const void* msg) {
  Guarded(channel, [&] { handler(channel, msg); });
}

}  // namespace rocklab::common
