#pragma once
/// @file
/// Reference marks from a ChArUco board (`[camera.video.board]`,
/// docs/video.md "Marks from a board"): the board's ArUco markers are found
/// (OpenCV's aruco), its chessboard corners placed from them and refined to
/// sub-pixel, and each corner becomes a mark with its rig coordinates. The
/// homography is then made from them as from typed marks (PlaneMap).

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "video/video_config.h"

namespace rocklab::video {

/// The board's corners found in `gray` (8-bit) as marks: image position as
/// seen (distorted, pixel centres at integers) and rig coordinates from the
/// board's layout and origin. `where` names the image in errors.
/// @throws std::runtime_error "RIG:LINE: key 'camera.video.board': ..." naming
///   `where` when fewer than board.min_corners corners are found.
std::vector<Mark> FindBoardMarks(const BoardConfig& board, const cv::Mat& gray, const std::string& rig_path,
                                 const std::string& where);

/// The board's image: `board.image` (an image file, or a video's first
/// frame), else the first frame of `video` (the input being tracked), as
/// 8-bit grey.
/// @throws std::runtime_error naming the file when it cannot be read.
cv::Mat ReadBoardImage(const BoardConfig& board, const std::string& video, std::string* where);

/// `config` with its marks found on its board (unchanged without one);
/// `video` is the input's file ("" for a live device, which then needs
/// `board.image`).
/// @throws std::runtime_error as the two above.
VideoConfig ResolveBoardMarks(VideoConfig config, const std::string& video);

}  // namespace rocklab::video
