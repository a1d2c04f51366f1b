#pragma once
/// @file
/// Lens intrinsics and distortion from a video of a chessboard (OpenCV's
/// findChessboardCorners, cornerSubPix and calibrateCamera): the
/// `rocklab camera-calibrate` command. k3 is held at 0 (a few dozen views of
/// a machine-vision lens do not determine it; k1, k2, p1, p2 are fitted).

#include <optional>
#include <string>

#include "video/video_config.h"

namespace rocklab::video {

struct ChessboardOptions {
  int cols{9};             ///< inner corners along a row
  int rows{6};             ///< inner corners along a column
  double square_m{0.025};  ///< side of a square, m
  int every{0};            ///< look at every Nth frame; 0 = so that about 200 frames are looked at
  int max_views{40};       ///< views used at most (evenly spread over those found)
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

struct CalibrationResult {
  Intrinsics intrinsics;     ///< with rms_reprojection_px and views
  int frames_read{};
  int frames_searched{};
  int boards_found{};
  double worst_view_rms_px{};  ///< largest per-view RMS reprojection error, px
};

/// @throws std::runtime_error naming the video when it cannot be read or
///         holds fewer than 3 views of the board.
CalibrationResult CalibrateFromVideo(const std::string& spec, const ChessboardOptions& options);

}  // namespace rocklab::video
