#pragma once
// `rocklab --version`: the version, the build type and the optional parts
// (video, MPI, HDF5, MATLAB, the monitor's server, Python), each present or not; for the plugins
// (common/plugin.h) whether the file is installed, and with `--load`
// whether it loads. Without --load nothing is opened, so --version stays
// within the start-up budget (docs/performance.md).

#include <string>

namespace rocklab::tools {

/// One line per item, the first "rocklab X.Y.Z" as before.
std::string VersionText(bool load, bool final_newline = true);

}  // namespace rocklab::tools
