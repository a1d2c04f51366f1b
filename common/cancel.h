#pragma once
/// @file
/// Stopping long work from outside (Ctrl-C in Python): a hook the work
/// polls, the exception that then ends it, and the two ways the hook reaches
/// work that cannot take it as an argument:
///
/// - CancelToken: work split over threads. Only the thread that made the
///   token calls the hook (Python's hook takes the GIL and is not
///   thread-safe); it sets a flag every other thread reads. The caller's
///   thread keeps polling while it waits for the others (RunOnThreads).
/// - ThreadCancelScope: the file readers (LogReader, the DAQ's text
///   sources, the theta record, acceleration and polygon readers) poll the
///   hook set for their thread (PollThreadCancel, throwing ReadCancelled),
///   so a caller stops a read without a hook in every reader's signature.
///   None set (the CLI): one thread-local load per row.

#include <atomic>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <thread>

namespace rocklab::common {

/// Thrown by work whose cancel hook returned true. Not an input error:
/// nothing is wrong with the input.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

/// Returns true to stop the work that polls it. Called on the work's
/// calling thread only; must not throw. Empty: never stops.
using CancelHook = std::function<bool()>;

/// @throws Cancelled when `cancelled` is set and returns true.
inline void ThrowIfCancelled(const CancelHook& cancelled) {
  if (cancelled && cancelled()) throw Cancelled();
}

/// A cancel hook shared with worker threads (see the file's comment).
class CancelToken {
 public:
  /// The calling thread becomes the one that polls `hook`.
  explicit CancelToken(CancelHook hook = {});
  CancelToken(const CancelToken&) = delete;
  CancelToken& operator=(const CancelToken&) = delete;
  /// True once cancelled; on the thread that made the token, polls the
  /// hook first. Never throws.
  bool Check() const;
  /// @throws Cancelled when Check() is true.
  void ThrowIfCancelled() const {
    if (Check()) throw Cancelled();
  }
  /// From any thread: every later Check() is true.
  void Cancel() const { cancelled_.store(true, std::memory_order_relaxed); }
  /// False when there is no hook (Check is then only the flag).
  bool has_hook() const { return static_cast<bool>(hook_); }

 private:
  CancelHook hook_;
  std::thread::id owner_;
  mutable std::atomic<bool> cancelled_{false};
};

/// Runs work(0) on the calling thread and work(1) .. work(threads - 1) on
/// new threads, and joins them; while it waits, polls `token` every 10 ms
/// and, once it says stop, lets the workers see it (their own Check()
/// must then end them). The first exception of any work is rethrown after
/// every thread has ended; Cancelled when the token stopped the work.
/// @param threads >= 1.
void RunOnThreads(int threads, const CancelToken& token, const std::function<void(int)>& work);

/// Sets the cancel hook of the file readers on this thread for its
/// lifetime (the previous one back after).
class ThreadCancelScope {
 public:
  explicit ThreadCancelScope(CancelHook hook);
  ~ThreadCancelScope();
  ThreadCancelScope(const ThreadCancelScope&) = delete;
  ThreadCancelScope& operator=(const ThreadCancelScope&) = delete;

 private:
  const CancelHook* previous_;
  CancelHook hook_;
};

/// PollThreadCancel calls the hook once in this many calls: a reader calls
/// it once per row, line or event (a few us each; the hook itself reads a
/// clock).
inline constexpr unsigned kReadPollRows = 256;

/// What PollThreadCancel throws. Not a std::exception (nor a Cancelled):
/// the readers turn a std::exception into a bad-input report or status,
/// which a stop is not, so it passes through their handlers to the caller
/// that set the hook.
struct ReadCancelled {};

/// Polls this thread's reader hook (ThreadCancelScope), once in
/// kReadPollRows calls; a no-op when none is set.
/// @throws ReadCancelled when it returns true.
void PollThreadCancel();

}  // namespace rocklab::common
