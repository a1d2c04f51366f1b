#pragma once
/// @file
/// `rocklab track --overlay OUT.mkv`: the video again with what the tracker
/// made of each frame drawn on it, for a person to scrub through: each
/// identified LED (green circle and its name), each LED whose blob was
/// rejected (orange, its name and why: merged, ambiguous, inconsistent,
/// outlier), the blobs no LED took (red cross: reflections, oversize
/// blobs), and the frame's number, time and theta. Written as MJPEG
/// through OpenCV's FFmpeg writer into Matroska (.mkv) or AVI (.avi),
/// beside the target and renamed when the read ended well: whole or not at
/// all (common::AtomicFile).

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "video/led_detector.h"
#include "video/led_tracker.h"

namespace rocklab::video {

/// What the source saw in one frame (video_source.h's ObserveFrames).
struct FrameView {
  const cv::Mat* gray{};                   ///< the 8-bit image tracked
  const std::vector<Blob>* blobs{};        ///< every blob found
  const std::vector<LedSample>* samples{};  ///< one per LED, in the rig's order
  const std::vector<std::string>* led_names{};
  double time_s{};
  int64_t number{};   ///< frame number (from the container's times)
  double theta_rad{};  ///< the tracker's rigid fit of this frame; NaN without one
};

class OverlayWriter {
 public:
  /// @throws std::runtime_error naming `path` when its extension is not
  ///         .mkv or .avi or OpenCV cannot open a writer there.
  OverlayWriter(const std::string& path, double fps, int width, int height);
  ~OverlayWriter();
  OverlayWriter(const OverlayWriter&) = delete;
  OverlayWriter& operator=(const OverlayWriter&) = delete;
  /// Draws and writes one frame. Never throws (a frame of another size is
  /// counted and left out).
  void Write(const FrameView& view);
  /// Closes the video and renames it over the target.
  /// @throws std::runtime_error naming the target.
  void Commit();
  int64_t frames() const { return frames_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int64_t frames_{0};
};

}  // namespace rocklab::video
