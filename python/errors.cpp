// Python's view of the library's errors, the progress hook, JSON to Python.
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/text.h"
#include "export/export.h"
#include "pipeline/option_error.h"
#include "python/bindings.h"

namespace rocklab::python {

namespace {

// Raises `type` with `what` made printable (common::PrintableLines): a
// message always well-formed UTF-8, so never lost (PyErr_SetString of bytes
// that are not UTF-8 raises the exception with no message at all), and
// never a terminal control sequence or a megabyte line from a hostile file.
void Raise(PyObject* type, const char* what) {
  const std::string text = common::PrintableLines(what);
  PyErr_SetString(type, text.empty() ? "(no message)" : text.c_str());
}

}  // namespace

void RegisterErrors(py::module_& /*m*/) {
  // The standard exceptions as pybind11 maps them, their messages made
  // printable; pybind11's own exceptions and Python's pass through.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const py::error_already_set&) {
      throw;
    } catch (const py::builtin_exception&) {
      throw;
    } catch (const std::bad_alloc&) {
      PyErr_SetString(PyExc_MemoryError, "out of memory");
    } catch (const std::out_of_range& e) {
      Raise(PyExc_IndexError, e.what());
    } catch (const std::overflow_error& e) {
      Raise(PyExc_OverflowError, e.what());
    } catch (const std::logic_error& e) {  // invalid_argument, domain_error, length_error
      Raise(PyExc_ValueError, e.what());
    } catch (const std::range_error& e) {
      Raise(PyExc_ValueError, e.what());
    } catch (const std::exception& e) {
      Raise(PyExc_RuntimeError, e.what());
    }
  });
  // Registered last, tried first: the library's own errors.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      const std::string message = common::PrintableLines(e.what());
      py::object error = py::reinterpret_steal<py::object>(PyObject_CallFunction(
          PyExc_OSError, "isN", e.error_number(), message.c_str(),
          PyUnicode_DecodeFSDefaultAndSize(e.path().data(), static_cast<Py_ssize_t>(e.path().size()))));
      if (error) PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
    } catch (const pipeline::OptionError& e) {
      Raise(PyExc_ValueError, e.what());  // the CLI's exit-2 message
    } catch (const exporter::InputError& e) {
      Raise(PyExc_OSError, e.what());
    }
  });
}

void ThrowIfUnreadable(const std::string& path, const std::string& message) {
  if (::access(path.c_str(), R_OK) != 0) throw FileError(errno, message, path);
}

// The signal check's period: Ctrl-C's KeyboardInterrupt within it (and the
// work's own poll gap); the callback's, a progress display's rate.
constexpr std::chrono::milliseconds kSignalCheckPeriod{20};
constexpr std::chrono::milliseconds kProgressCallbackPeriod{100};

ProgressHook::ProgressHook(py::object callback, double total)
    : callback_(std::move(callback)),
      total_(total),
      next_(std::chrono::steady_clock::now() + kSignalCheckPeriod),
      next_callback_(std::chrono::steady_clock::now() + kProgressCallbackPeriod) {}

ProgressHook::~ProgressHook() = default;

py::object ProgressHook::Total() const {
  return total_ > 0 ? py::object(py::float_(total_)) : py::none();
}

void ProgressHook::Call(double done, std::chrono::steady_clock::time_point now) {
  next_ = now + kSignalCheckPeriod;
  py::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  if (callback_.is_none() || now < next_callback_) return;
  next_callback_ = now + kProgressCallbackPeriod;
  callback_(done, Total());
}

bool ProgressHook::Poll(double done) noexcept {
  done_ = done;
  if (stopped_) return true;
  try {
    Update(done);
  } catch (...) {
    stopped_ = std::current_exception();
  }
  return stopped_ != nullptr;
}

void ProgressHook::Done(double done) {
  if (callback_.is_none()) return;
  py::gil_scoped_acquire gil;
  callback_(done, Total());
}

}  // namespace rocklab::python
