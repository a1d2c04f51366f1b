#pragma once
/// @file
/// What a bus counts: messages that did not decode and handler exceptions,
/// per channel, each logged at most once a second per channel (the counts
/// hold the rest). A decorator bus shares the counters of the bus it wraps
/// (common/bus.h).

#include <cstdint>
#include <functional>
#include <map>
#include <string>

namespace rocklab::common {

class BusCounters {
 public:
  /// Counts a message on `channel` that did not decode (`why`) and warns.
  void CountDecodeError(const std::string& channel, const char* why);
  /// Runs `handler` on one message; an exception is caught, counted and
  /// logged, never passed on.
  void Dispatch(const std::function<void(const std::string&, const void*, int)>& handler,
                const std::string& channel, const void* data, int size);
  /// As Dispatch, for a handler given the published object (common/bus.h).
  void DispatchValue(const std::function<void(const std::string&, const void*)>& handler,
                     const std::string& channel, const void* msg);

  const std::map<std::string, std::int64_t>& decode_errors() const { return decode_errors_; }
  const std::map<std::string, std::int64_t>& handler_errors() const { return handler_errors_; }
  std::int64_t decode_error_count() const;
  std::int64_t handler_error_count() const;

 private:
  void Warn(std::map<std::string, double>& last, const std::string& channel, const std::string& what);
  template <class Call>
  void Guarded(const std::string& channel, Call&& call);

  std::map<std::string, std::int64_t> decode_errors_, handler_errors_;
  std::map<std::string, double> last_decode_warning_s_, last_handler_warning_s_;  // host s
};

}  // namespace rocklab::common
