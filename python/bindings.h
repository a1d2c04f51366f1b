#pragma once
// What the binding files of the Python module share: registration of each
// part, the errors as Python sees them, the progress and interrupt hook of
// long calls, and numpy arrays that own C++ vectors.

#include <chrono>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "common/cancel.h"
#include "model/cancel.h"

namespace rocklab::python {

namespace py = pybind11;

void RegisterErrors(py::module_& m);
void RegisterModel(py::module_& m);
void RegisterLogs(py::module_& m);
void RegisterAnalysis(py::module_& m);

/// A file that cannot be read: raised in Python as OSError(errno, message,
/// path) (FileNotFoundError, PermissionError, ... by errno).
class FileError : public std::runtime_error {
 public:
  FileError(int error_number, const std::string& message, std::string path)
      : std::runtime_error(message), errno_(error_number), path_(std::move(path)) {}
  int error_number() const { return errno_; }
  const std::string& path() const { return path_; }

 private:
  int errno_;
  std::string path_;
};

/// Rethrows the library's error `message` about file `path` as FileError
/// when the file cannot be opened for reading (the CLI's message kept),
/// and returns otherwise (the caller then raises ValueError).
void ThrowIfUnreadable(const std::string& path, const std::string& message);

/// The progress callback of a long call and the interrupt check. Called
/// with the GIL released; at most every 20 ms it takes the GIL and checks
/// for signals (Ctrl-C raises KeyboardInterrupt through the call), and at
/// most every 100 ms of those it calls `callback(done, total)` when one
/// was given (total None when unknown).
/// Update lets a Python exception through as py::error_already_set; Poll
/// keeps it (for the library's loops, which must not see it), and the
/// call raises it once the loop has stopped (RethrowIfStopped).
class ProgressHook {
 public:
  /// `callback`: None or a callable (done, total); total <= 0: None.
  ProgressHook(py::object callback, double total);
  ~ProgressHook();
  ProgressHook(const ProgressHook&) = delete;
  ProgressHook& operator=(const ProgressHook&) = delete;
  /// Cheap when no call is due (one clock read).
  void Update(double done) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_) Call(done, now);
  }
  /// Update that keeps the exception instead of throwing it; then and
  /// afterwards returns true (the caller stops). Never throws.
  bool Poll(double done) noexcept;
  /// Poll with the last `done` given, as the model's cancel hook
  /// (model/cancel.h) of work on this thread; the hook outlives neither.
  model::CancelHook Cancel() {
    return [this] { return Poll(done_); };
  }
  /// Raises the exception Poll kept, if any.
  void RethrowIfStopped() const {
    if (stopped_) std::rethrow_exception(stopped_);
  }
  bool stopped() const { return stopped_ != nullptr; }
  /// Reports `done` once more, whatever the time (with the GIL released).
  void Done(double done);
  /// The total passed to the callback (<= 0: None).
  void set_total(double total) { total_ = total; }

 private:
  void Call(double done, std::chrono::steady_clock::time_point now);
  py::object Total() const;
  py::object callback_;
  double total_;
  double done_{};
  std::exception_ptr stopped_;  // the callback's or the signal's exception
  std::chrono::steady_clock::time_point next_;           // signal check
  std::chrono::steady_clock::time_point next_callback_;
};

/// Runs `work` (on this thread, the GIL released by the caller) with the
/// file readers polling `hook` (common::ThreadCancelScope). When the hook
/// stopped it (common::ReadCancelled from a reader, model::Cancelled from
/// the model), raises the hook's exception (KeyboardInterrupt).
template <typename F>
auto RunStoppable(ProgressHook& hook, F&& work) -> decltype(work()) {
  const common::ThreadCancelScope reading(hook.Cancel());
  try {
    return work();
  } catch (const common::ReadCancelled&) {
    hook.RethrowIfStopped();
    throw std::runtime_error("the read was stopped");  // not reached: only the hook stops it
  } catch (const common::Cancelled&) {
    hook.RethrowIfStopped();
    throw;
  }
}

/// A 1-D numpy array that takes over `values` (no copy).
template <typename T>
py::array_t<T> OwnedArray(std::vector<T>&& values) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule free(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(static_cast<py::ssize_t>(owned->size()), owned->data(), free);
}

}  // namespace rocklab::python
