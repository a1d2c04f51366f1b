#pragma once
/// @file
/// Stopping the model's long computations (a fit, a posterior's sampling)
/// from outside, e.g. on Ctrl-C in Python: the hook the work polls between
/// its steps and inside its model runs, and the exception that then ends
/// it (common/cancel.h: the same types, also for work over threads).

#include <cstddef>

#include "common/cancel.h"

namespace rocklab::model {

/// Thrown by a computation whose cancel hook returned true. Not a FitError:
/// nothing is wrong with the input.
using common::Cancelled;
/// Returns true to stop the computation that polls it. Called on the
/// computation's calling thread; must not throw. Empty: never stops.
using common::CancelHook;
using common::CancelToken;
using common::ThrowIfCancelled;

/// Samples of a scan or model run between two polls of a cancel hook.
inline constexpr std::size_t kCancelPollSamples = 16384;

}  // namespace rocklab::model
