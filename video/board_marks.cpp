#include "video/board_marks.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace rocklab::video {

std::vector<Mark> FindBoardMarks(const BoardConfig& board, const cv::Mat& gray, const std::string& rig_path,
                                 const std::string& where) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(BoardDictionaryIndex(board.dictionary));
  const cv::Ptr<cv::aruco::CharucoBoard> layout =
      cv::aruco::CharucoBoard::create(board.squares_x, board.squares_y, static_cast<float>(board.square_m),
                                      static_cast<float>(board.marker_m), dict);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, dict, marker_corners, marker_ids);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  if (!marker_ids.empty()) {
    // Placed from the neighbouring markers (a local homography), then
    // refined to sub-pixel on the chessboard's saddle points.
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, layout, corners, ids);
  }
  if (ids.size() >= 2) {
    // OpenCV 4.6 places the corners from the markers' outlines and refines
    // them in windows that can be too small to leave that start: on the
    // tests' rendered boards they stayed 0.45 to 0.81 px off. Refined again here in
    // the largest window that keeps the markers out: 0.7 of the margin
    // between a marker and its square's edge, at the board's scale in the
    // image (neighbouring corners' distance over square_m).
    double sum_px = 0;
    int pairs = 0;
    for (std::size_t i = 0; i + 1 < ids.size(); ++i) {
      if (ids[i + 1] == ids[i] + 1 && (ids[i] + 1) % (board.squares_x - 1) != 0) {
        sum_px += cv::norm(corners[i + 1] - corners[i]);
        ++pairs;
      }
    }
    if (pairs > 0) {
      const double margin_px = 0.5 * (board.square_m - board.marker_m) * sum_px / pairs / board.square_m;
      const int w = std::clamp(static_cast<int>(std::floor(0.7 * margin_px)), 2, 15);
      cv::cornerSubPix(gray, corners, cv::Size(w, w), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-3));
    }
  }
  const int all = (board.squares_x - 1) * (board.squares_y - 1);
  if (static_cast<int>(ids.size()) < board.min_corners) {
    throw std::runtime_error(rig_path + ":" + std::to_string(board.line) + ": key 'camera.video.board': " +
                             std::to_string(ids.size()) + " of the board's " + std::to_string(all) +
                             " corners found in " + where + " (" + std::to_string(marker_ids.size()) +
                             " markers), fewer than min_corners " + std::to_string(board.min_corners) +
                             ": is the board in view, flat and lit, and are dictionary and squares "
                             "those printed on it?");
  }
  std::vector<Mark> marks;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    // OpenCV's chessboardCorners are the corners' places in the board's
    // frame (x across, y down from its top-left corner), in the units of
    // square_m: metres.
    const cv::Point3f& b = layout->chessboardCorners[static_cast<std::size_t>(ids[i])];
    Mark m;
    m.u_px = corners[i].x;
    m.v_px = corners[i].y;
    m.x_m = board.origin_x_m + static_cast<double>(b.x);
    m.z_m = board.origin_z_m - static_cast<double>(b.y);
    m.line = board.line;
    marks.push_back(m);
  }
  return marks;
}

cv::Mat ReadBoardImage(const BoardConfig& board, const std::string& video, std::string* where) {
  const std::string path = board.image.empty() ? video : board.image;
  *where = board.image.empty() ? "the first frame of " + path : path;
  cv::Mat frame;
  if (!board.image.empty() && cv::haveImageReader(path)) frame = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (frame.empty()) {
    cv::VideoCapture cap(path, cv::CAP_FFMPEG);  // as frame_reader: not GStreamer, which leaks probing USB
    if (cap.isOpened()) cap.read(frame);
    if (!frame.empty() && !board.image.empty()) *where = "the first frame of " + path;
  }
  if (frame.empty()) {
    throw std::runtime_error("cannot read the board's image '" + path + "' (an image or a video; " +
                             "[camera.video.board] image)");
  }
  cv::Mat gray;
  if (frame.channels() == 3) {
    cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
  } else if (frame.channels() == 4) {
    cv::cvtColor(frame, gray, cv::COLOR_BGRA2GRAY);
  } else {
    gray = frame;
  }
  if (gray.depth() != CV_8U) gray.convertTo(gray, CV_8U, gray.depth() == CV_16U ? 1.0 / 256 : 1.0);
  return gray;
}

VideoConfig ResolveBoardMarks(VideoConfig config, const std::string& video) {
  if (!config.board.present) return config;
  if (video.empty() && config.board.image.empty()) {
    throw std::runtime_error(config.rig_path + ":" + std::to_string(config.board.line) +
                             ": key 'camera.video.board': a live camera needs the board's image (key 'image')");
  }
  std::string where;
  const cv::Mat gray = ReadBoardImage(config.board, video, &where);
  config.marks = FindBoardMarks(config.board, gray, config.rig_path, where);
  return config;
}

}  // namespace rocklab::video
