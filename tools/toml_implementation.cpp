// toml++'s compiled part (the parser, tables, nodes) in the rocklab command
// itself, as the library provides for (TOML_IMPLEMENTATION in one
// translation unit): with --as-needed the command then does not load
// libtomlplusplus.so.3 at every start (docs/performance.md, "Start-up,
// fourth round"). The libraries, tests, plugins and the Python module link
// the shared library as before; the same version's code either way.
#define TOML_IMPLEMENTATION
#include <toml++/toml.h>
