#include "daq/pacer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

namespace rocklab::daq {

Pacer::Pacer(double speed) : speed_(speed) {
  if (!(speed >= 0) || !std::isfinite(speed)) {
    throw std::invalid_argument("pacer: speed must be >= 0 (0 = as fast as possible)");
  }
}

void Pacer::Restart(double t0_s) {
  t0_s_ = t0_s;
  host0_ = Clock::now();
}

bool Pacer::WaitFor(double t_s, const std::atomic<bool>& stop) {
  if (stop.load()) return false;
  if (speed_ == 0) return true;
  if (!t0_s_) {
    t0_s_ = t_s;
    host0_ = Clock::now();
    return true;
  }
  const auto due = host0_ + std::chrono::duration_cast<Clock::duration>(
                                std::chrono::duration<double>((t_s - *t0_s_) / speed_));
  constexpr auto kPoll = std::chrono::milliseconds(20);
  while (true) {
    const auto now = Clock::now();
    if (now >= due) {
      lag_s_ = std::chrono::duration<double>(now - due).count();
      return true;
    }
    if (stop.load()) return false;
    std::this_thread::sleep_for(std::min<Clock::duration>(due - now, kPoll));
  }
}

}  // namespace rocklab::daq
