// Python's view of the library's errors, the progress hook, JSON to Python.
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "export/export.h"
#include "pipeline/option_error.h"
#include "python/bindings.h"

namespace rocklab::python {

void RegisterErrors(py::module_& /*m*/) {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      py::object error = py::reinterpret_steal<py::object>(PyObject_CallFunction(
          PyExc_OSError, "isz", e.error_number(), e.what(), e.path().c_str()));
      if (error) PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
    } catch (const pipeline::OptionError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());  // the CLI's exit-2 message
    } catch (const exporter::InputError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    }
  });
}

void ThrowIfUnreadable(const std::string& path, const std::string& message) {
  if (::access(path.c_str(), R_OK) != 0) throw FileError(errno, message, path);
}

ProgressHook::ProgressHook(py::object callback, double total)
    : callback_(std::move(callback)),
      total_(total),
      next_(std::chrono::steady_clock::now() + std::chrono::milliseconds(100)) {}

ProgressHook::~ProgressHook() = default;

py::object ProgressHook::Total() const {
  return total_ > 0 ? py::object(py::float_(total_)) : py::none();
}

void ProgressHook::Call(double done, std::chrono::steady_clock::time_point now) {
  next_ = now + std::chrono::milliseconds(100);
  py::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  if (!callback_.is_none()) callback_(done, Total());
}

void ProgressHook::Done(double done) {
  if (callback_.is_none()) return;
  py::gil_scoped_acquire gil;
  callback_(done, Total());
}

}  // namespace rocklab::python
