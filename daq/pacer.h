#pragma once
/// @file
/// Paces a recorded stream on its own clock (a file source's sample clock,
/// a log's event stamps): real time, a speed factor, or as fast as possible.
/// The one pacer of the DAQ's file sources and of log replay. The outputs
/// never depend on the pace (every message carries the recorded clock, not
/// the host's clock).

#include <atomic>
#include <chrono>
#include <optional>

namespace rocklab::daq {

class Pacer {
 public:
  /// @param speed sample-clock seconds per host second: 1 = real time,
  ///        2 = twice as fast; 0 = as fast as possible (no waiting).
  /// @throws std::invalid_argument when speed < 0 or not finite.
  explicit Pacer(double speed);

  /// Blocks until the host clock reaches the moment of sample time t_s (s)
  /// relative to the first sample seen, or until `stop` becomes true (polled
  /// every 20 ms). Returns false when stopped. A sample time behind the
  /// pace (or going backwards) returns at once.
  bool WaitFor(double t_s, const std::atomic<bool>& stop);

  /// Makes sample time t0_s (s) due now: later WaitFor calls pace relative
  /// to it (a replay's window start, again on each loop).
  void Restart(double t0_s);

  /// Host seconds the pacer is behind the sample clock (0 when on time).
  double lag_s() const { return lag_s_; }
  double speed() const { return speed_; }

 private:
  using Clock = std::chrono::steady_clock;
  double speed_;
  std::optional<double> t0_s_;
  Clock::time_point host0_;
  double lag_s_{0};
};

}  // namespace rocklab::daq
