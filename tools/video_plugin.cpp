#include "tools/video_plugin.h"

#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "common/plugin.h"

namespace rocklab::tools {
namespace {

struct Opened {
  const video::PluginCalls* calls{};
  std::string error;  // when calls is nullptr
};

const Opened& Open() {
  static Opened opened;
  static std::once_flag once;
  std::call_once(once, [] {
    std::string why;
    opened.calls =
        common::OpenPlugin<video::PluginCalls>(video::kPluginFile, video::kPluginEntry, video::kPluginVersion, why);
    if (opened.calls != nullptr) return;
    const std::string package = video::kPluginPackage;
    opened.error = common::PluginInstalled(video::kPluginFile)
                       ? "the video plugin does not load: " + why + " (apt-get install --reinstall " + package + ")"
                       : "video inputs, track and camera-calibrate are in the package " + package +
                             ", which is not installed (apt-get install " + package + "; looked for " +
                             common::PluginPath(video::kPluginFile) + ")";
  });
  return opened;
}

std::unique_ptr<daq::Source> OpenVideoFile(const std::string& spec, const daq::SourceOptions& options) {
  return VideoPlugin().open_source(spec, false, options);
}

std::unique_ptr<daq::Source> OpenVideoDevice(const std::string& spec, const daq::SourceOptions& options) {
  return VideoPlugin().open_source(spec, true, options);
}

}  // namespace

const video::PluginCalls& VideoPlugin() {
  const Opened& opened = Open();
  if (opened.calls == nullptr) throw std::runtime_error(opened.error);
  return *opened.calls;
}

void RegisterVideoSources() {
  daq::RegisterSourceForm("video:", &OpenVideoFile);
  daq::RegisterSourceForm("v4l2:", &OpenVideoDevice);
}

std::string VideoPluginState(bool load) {
  const std::string path = common::PluginPath(video::kPluginFile);
  if (!common::PluginInstalled(video::kPluginFile)) {
    return std::string("not installed (apt-get install ") + video::kPluginPackage + ")";
  }
  if (!load) return "installed (" + path + ")";
  const Opened& opened = Open();
  return opened.calls != nullptr ? "loads (" + path + ")" : "does not load: " + opened.error;
}

}  // namespace rocklab::tools
