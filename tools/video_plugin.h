#pragma once
// The rocklab command's side of the video plugin (video/plugin.h): opened
// at the first `video:` / `v4l2:` input, `track` or `camera-calibrate`, so
// no other command maps OpenCV and the ~240 libraries it brings
// (docs/performance.md, Start-up).

#include <string>

#include "video/plugin.h"

namespace rocklab::tools {

/// The plugin's calls, opened at the first call (then kept).
/// @throws std::runtime_error naming the package (rocklab-video) and the
///   file when it is not installed, and dlopen's reason when it does not load.
const video::PluginCalls& VideoPlugin();

/// Registers `video:` and `v4l2:` with daq::OpenSource (--input of daq,
/// run, reconstruct, replay --rig, and daq --config's input); the plugin is
/// opened only when such an input is opened.
void RegisterVideoSources();

/// For `rocklab --version`: "installed (PATH)" or "not installed (apt-get
/// install rocklab-video)"; with `load`, whether it loads ("loads (PATH)"
/// or the reason it does not).
std::string VideoPluginState(bool load);

}  // namespace rocklab::tools
