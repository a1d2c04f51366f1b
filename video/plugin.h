#pragma once
/// @file
/// The video plugin's interface (lib/rocklab/plugins/rocklab-video.so, package
/// rocklab-video): what the `rocklab` command calls for `video:` and
/// `v4l2:` inputs, `track` and `camera-calibrate`. No OpenCV here: the
/// command includes this header and opens the plugin (tools/video_plugin.h)
/// only when one of those is asked for; the plugin
/// (tools/video_plugin_main.cpp) holds video/ and OpenCV.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "daq/source.h"
#include "video/camera_calibration.h"  // ChessboardOptions; no OpenCV

namespace rocklab::video {

/// The plugin's entry: `extern "C" const PluginCalls* rocklab_video_plugin()`.
inline constexpr const char* kPluginEntry = "rocklab_video_plugin";
inline constexpr const char* kPluginFile = "rocklab-video.so";
/// The Debian package that installs it (cmake/RocklabPackage.cmake).
inline constexpr const char* kPluginPackage = "rocklab-video";
/// PluginCalls::version of this build; a plugin with another is refused.
inline constexpr int kPluginVersion = 4;  // 2: TrackRequest::fps_hz; 3: daq::Source::summary, TrackRequest::overlay;
                                          // 4: TrackRequest::daq

/// What `rocklab track` did, for its `--json` (built by the command,
/// tools/cmd_track.cpp; no JSON in the plugin).
struct TrackResult {
  std::int64_t frames{};        ///< video frames tracked
  std::int64_t rows{};          ///< rows written to --out (the DAQ's samples with --daq)
  double rate_hz{};             ///< the video's frame rate
  std::int64_t dropped{}, drop_places{}, missing_at_end{};
  std::int64_t fits{};          ///< frames with a rigid fit
  std::int64_t led_missing{}, occlusions{}, merged{}, ambiguous{}, inconsistent{}, outliers{}, saturated{};
  std::int64_t reflections{};
  std::string summary;          ///< the line printed on stderr
  /// --daq: the clocks (video/daq_sync.h's ClockFit) and the merge's counts.
  bool synced{false};
  double offset_s{}, offset_se_s{}, drift_ppm{}, drift_se_ppm{};
  double residual_rms_s{}, residual_max_s{}, expected_rms_s{};
  int edges_video{}, edges_daq{}, edges_paired{};
  std::int64_t rows_before{}, rows_after{}, rows_in_gaps{};
  /// sync = "table": the clocks from the table's motion (no edges); the
  /// correlation of the motions and the video's residual about the fit, m.
  bool by_table{false};
  double correlation{}, motion_residual_m{};
  int motion_samples{};
};

/// `rocklab track`'s options (tools/cmd_track.cpp).
struct TrackRequest {
  std::string video;     ///< file, image pattern, v4l2:/dev/videoN; a leading video: accepted
  std::string rig_path;
  std::string out_csv;
  std::int64_t max_frames{0};  ///< 0: all
  const std::atomic<bool>* stop{};  ///< Ctrl-C (tools::InstallStopSignals)
  double fps_hz{0};  ///< the camera's true frame rate over the rig's and the container's; 0: none given
  /// A video of the detections drawn on each frame (`--overlay`), written
  /// whole or not at all; empty: none.
  std::string overlay;
  /// The DAQ's raw record (any --input file form) with the sync LED's
  /// drive (`--daq`): the video's channels are merged into it on its
  /// clock (video/daq_sync.h); empty: the video's own clock.
  std::string daq;
  TrackResult* result{};  ///< filled when not null (`--json`)
};

/// `rocklab camera-calibrate`'s options (tools/cmd_camera_calibrate.cpp).
struct CalibrateRequest {
  std::string video;
  std::string board{"9x6"};  ///< inner corners COLSxROWS
  std::string out;
  ChessboardOptions chessboard;  ///< cols and rows from `board` by the plugin
  /// Filled when not null (`--json`); the text then goes to stderr.
  CalibrationResult* result{};
};

/// The plugin's functions. Errors are exceptions, as the commands' own:
/// pipeline::OptionError for bad options or input (exit 2), others (exit 1).
struct PluginCalls {
  int version;
  /// video_source.h's OpenVideoSource.
  std::unique_ptr<daq::Source> (*open_source)(const std::string& spec, bool device,
                                              const daq::SourceOptions& options);
  /// The commands' runs; the exit code.
  int (*track)(const TrackRequest& request);
  int (*camera_calibrate)(const CalibrateRequest& request);
};

}  // namespace rocklab::video
