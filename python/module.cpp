// rocklab._rocklab: the native part of `import rocklab` (python/rocklab/
// holds the public functions, their docstrings and the result classes).
#include "python/bindings.h"

PYBIND11_MODULE(_rocklab, m) {
  m.doc() = "rocklab's C++ core (use the package rocklab, not this module)";
  m.attr("__version__") = ROCKLAB_VERSION;  // the build's, as `rocklab --version`
  rocklab::python::RegisterErrors(m);
  rocklab::python::RegisterModel(m);
  rocklab::python::RegisterLogs(m);
  rocklab::python::RegisterAnalysis(m);
}
