#pragma once
/// @file
/// Stopping the model's long computations (a fit, a posterior's sampling)
/// from outside, e.g. on Ctrl-C in Python: a hook the work polls between
/// its steps, and the exception that then ends it.

#include <cstddef>
#include <functional>
#include <stdexcept>

namespace rocklab::model {

/// Thrown by a computation whose cancel hook returned true. Not a FitError:
/// nothing is wrong with the input.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

/// Returns true to stop the computation that polls it. Called on the
/// computation's calling thread; must not throw. Empty: never stops.
using CancelHook = std::function<bool()>;

/// Samples of a scan or model run between two polls of a cancel hook.
inline constexpr std::size_t kCancelPollSamples = 16384;

/// @throws Cancelled when `cancelled` is set and returns true.
inline void ThrowIfCancelled(const CancelHook& cancelled) {
  if (cancelled && cancelled()) throw Cancelled();
}

}  // namespace rocklab::model
