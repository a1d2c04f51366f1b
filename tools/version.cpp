#include "tools/version.h"

#include <string>

#include "common/plugin.h"
#include "tools/hdf5_plugin.h"
#include "tools/monitor_plugin.h"
#ifdef ROCKLAB_HAVE_VIDEO
#include "tools/video_plugin.h"
#endif
#ifdef ROCKLAB_HAVE_MPI
#include "sweep/mpi_plugin.h"
#endif

namespace rocklab::tools {
namespace {

// A plugin of the rocklab package: installed or not, and with `load` whether it loads.
template <typename Calls>
std::string PluginState(const char* file, const char* entry, int version, bool load, bool global = false) {
  const std::string path = common::PluginPath(file);
  if (!common::PluginInstalled(file)) return "not installed (" + path + " missing: reinstall rocklab)";
  if (!load) return "installed (" + path + ")";
  std::string why;
  const Calls* calls = common::OpenPlugin<Calls>(file, entry, version, why, global);
  return calls != nullptr ? "loads (" + path + ")" : "does not load: " + why;
}

}  // namespace

std::string VersionText(bool load, bool final_newline) {
  std::string s = "rocklab " ROCKLAB_VERSION "\n";
  s += "build: " ROCKLAB_BUILD_TYPE "\n";
#ifdef ROCKLAB_HAVE_VIDEO
  s += "video (video:, v4l2:, track, camera-calibrate): " + VideoPluginState(load) + "\n";
#else
  s += "video (video:, v4l2:, track, camera-calibrate): not built (ROCKLAB_VIDEO; needs libopencv-dev and libopencv-contrib-dev)\n";
#endif
#ifdef ROCKLAB_HAVE_MPI
  s += "MPI (mpirun ... rocklab sweep): " +
       PluginState<sweep::MpiCalls>(sweep::kMpiPluginFile, sweep::kMpiPluginEntry, sweep::kMpiPluginVersion, load,
                                    /*global=*/true) +
       "\n";
#else
  s += "MPI (mpirun ... rocklab sweep): not built (ROCKLAB_MPI; needs libopenmpi-dev)\n";
#endif
  const std::string hdf5 =
      PluginState<Hdf5Calls>(kHdf5PluginFile, kHdf5PluginEntry, kHdf5PluginVersion, load);  // both in one plugin
  s += "HDF5 (export, sweep .h5): " + hdf5 + "\n";
  s += "MATLAB (export .mat, libmatio): " + hdf5 + "\n";
  s += "monitor (its HTTP server, libmicrohttpd): " +
       PluginState<MonitorCalls>(kMonitorPluginFile, kMonitorPluginEntry, kMonitorPluginVersion, load) + "\n";
#ifdef ROCKLAB_HAVE_PYTHON
  s += "Python (import rocklab): built\n";
#else
  s += "Python (import rocklab): not built (ROCKLAB_PYTHON; needs python3-dev, python3-numpy, pybind11-dev)\n";
#endif
  if (!final_newline) s.pop_back();
  return s;
}

}  // namespace rocklab::tools
