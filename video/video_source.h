#pragma once
/// @file
/// A camera's video as a DAQ source (`--input video:FILE`, `v4l2:/dev/videoN`):
/// frames (frame_reader.h), LED blobs (led_detector.h), identification
/// (led_tracker.h), the plane (plane_map.h), out as the rig's LED channels.
///
/// Channels, in order: for each LED of the rig's camera with a
/// `[camera.video]` section, its `<camera>.<led>.x` and `.z` channels (the
/// rig's names), delivered as raw = (metres - offset) / gain so the DAQ's
/// calibration turns them back into metres; NaN where the LED was not
/// identified. Then, per LED, `<camera>_<led>_area_px`, `_peak` (8-bit
/// level) and `_flags` (led_tracker.h's LedFlag bits), then per LED
/// `<camera>_<led>_sigma_x_m`, `_sigma_z_m` (the centroid's noise on the
/// plane, m): carried in RL_RAW and the track CSV, ignored by the
/// reconstruction. With a sync LED (`sync = "led"`), last
/// `<camera>_sync_level`: its mean 8-bit level (video/daq_sync.h).
///
/// Frame numbers come from the frame times (frame_reader.h), so a dropped
/// frame is a gap of the DAQ's sequence, counted like any other. Opening
/// throws (bad rig section, unreadable video); Next() never throws. A
/// device (v4l2:) is live: Next() says kIdle after 0.1 s without a frame,
/// and ends on SourceOptions::stop or after its idle_timeout_s.

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "daq/source.h"
#include "video/frame_reader.h"
#include "video/led_detector.h"
#include "video/led_tracker.h"
#include "video/overlay.h"

namespace rocklab::video {

/// What a video source counted.
struct VideoStats {
  FrameCounts frames;
  DetectorCounts detector;
  TrackCounts track;
  double mark_rms_m{};       ///< homography residual at the reference marks, m
  double mark_rms_px{};      ///< the same in the image, px
  double m_per_px{};         ///< plane scale at the marks, m/px
  double gate_m{};
  double rate_hz{};
  std::string rate_source;   ///< where the frame rate came from
  bool times_from_fps{};     ///< no timestamps: times are frame index / fps
  int width_px{}, height_px{};
  double exposure_s{};       ///< [camera.video] exposure_s: times are mid-exposure
  double readout_s{};        ///< [camera.video] readout_s: LEDs taken back to row 0's time
  bool device{};             ///< a live device: frames keep the driver's times
  /// [camera.video] sync = "led": the last channel is `<camera>_sync_level`,
  /// the sync LED's mean level (8-bit) around sync_led_px, seen
  /// sync_row_delay_s after the frame's time (its row's rolling-shutter delay).
  bool sync_led{};
  /// [camera.video] sync = "table": no sync channel; the clocks come from
  /// the table's motion (the LEDs' pivot corner) against sync_channel.
  bool sync_table{};
  std::string sync_channel;  ///< the DAQ column that drives the LED (or the table's displacement)
  double sync_row_delay_s{};
};

/// `spec`: a video file or image pattern (device false), or /dev/videoN.
/// Needs options.rig (the rig loaded from its file).
/// @throws std::invalid_argument without options.rig; std::runtime_error
///         naming the rig file (line, key) or the video.
std::unique_ptr<daq::Source> OpenVideoSource(const std::string& spec, bool device,
                                             const daq::SourceOptions& options);
/// The same with the camera's true frame rate given (`rocklab track --fps`),
/// over the rig's [camera.video] fps and the container's rate (Hz).
std::unique_ptr<daq::Source> OpenVideoSource(const std::string& spec, bool device,
                                             const daq::SourceOptions& options, std::optional<double> fps);
/// The counts of a source OpenVideoSource made; nullptr for any other source.
const VideoStats* VideoStatsOf(const daq::Source& source);
/// The counts of `stats` as one line for a summary: "(WxH px, R frames/s
/// from ...); N dropped in M places, ...; LED samples: ..." (`rocklab
/// track`, and daq::Source::summary for `reconstruct`).
std::string VideoSummary(const VideoStats& stats);
/// Calls `observer` with each frame as tracked (on the thread calling
/// Next(), before Next() returns it): `rocklab track --overlay`. `source`
/// must be OpenVideoSource's (else std::invalid_argument).
void ObserveFrames(daq::Source& source, std::function<void(const FrameView&)> observer);
/// Registers `video:` and `v4l2:` with daq::OpenSource (call once at start-up).
void RegisterSources();

}  // namespace rocklab::video
