#include "video/camera_calibration.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "video/frame_reader.h"

namespace rocklab::video {
namespace {
constexpr int kTargetSearched = 200;
}

void ChessboardOptions::Validate() const {
  if (cols < 3 || rows < 3 || cols > 100 || rows > 100) {
    throw std::invalid_argument("--board: inner corners COLSxROWS, each in [3, 100]");
  }
  if (cols == rows) throw std::invalid_argument("--board: COLS and ROWS must differ (a square board's orientation is ambiguous)");
  if (!(square_m > 0 && square_m <= 10)) throw std::invalid_argument("--square: the side in m, in (0, 10]");
  if (every < 0) throw std::invalid_argument("--every: >= 0");
  if (max_views < 3) throw std::invalid_argument("--max-views: >= 3");
}

CalibrationResult CalibrateFromVideo(const std::string& spec, const ChessboardOptions& o) {
  o.Validate();
  // The frames' times do not matter here: any rate serves image sequences.
  FrameReader reader(spec, false, 1.0);
  cv::VideoCapture probe(spec, spec.find('%') != std::string::npos ? cv::CAP_IMAGES : cv::CAP_FFMPEG);
  const double frame_count = probe.isOpened() ? probe.get(cv::CAP_PROP_FRAME_COUNT) : 0;
  probe.release();
  const int every = o.every > 0 ? o.every
                                : std::max(1, static_cast<int>(std::ceil(frame_count / kTargetSearched)));
  const cv::Size pattern(o.cols, o.rows);
  std::vector<cv::Point3f> board;
  for (int r = 0; r < o.rows; ++r) {
    for (int c = 0; c < o.cols; ++c) {
      board.emplace_back(static_cast<float>(c * o.square_m), static_cast<float>(r * o.square_m), 0.0f);
    }
  }
  CalibrationResult result;
  std::vector<std::vector<cv::Point2f>> found;
  cv::Mat gray;
  double t = 0;
  int64_t number = 0;
  cv::Size size;
  while (reader.Next(gray, t, number)) {
    const int index = result.frames_read++;
    size = gray.size();
    if (index % every != 0) continue;
    ++result.frames_searched;
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(gray, pattern, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE |
                                       cv::CALIB_CB_FAST_CHECK)) {
      continue;
    }
    cv::cornerSubPix(gray, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 50, 1e-3));
    found.push_back(std::move(corners));
  }
  result.boards_found = static_cast<int>(found.size());
  if (found.size() < 3) {
    throw std::runtime_error(spec + ": the " + std::to_string(o.cols) + "x" + std::to_string(o.rows) +
                             " board was found in " + std::to_string(found.size()) + " of " +
                             std::to_string(result.frames_searched) + " frames looked at; 3 views at least are needed");
  }
  std::vector<std::vector<cv::Point2f>> views;
  const std::size_t use = std::min<std::size_t>(found.size(), static_cast<std::size_t>(o.max_views));
  for (std::size_t i = 0; i < use; ++i) views.push_back(found[i * found.size() / use]);
  std::vector<std::vector<cv::Point3f>> objects(views.size(), board);
  cv::Mat k, d, std_intrinsics, std_extrinsics, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(objects, views, size, k, d, rvecs, tvecs, std_intrinsics, std_extrinsics,
                                         per_view, cv::CALIB_FIX_K3);
  Intrinsics& in = result.intrinsics;
  in.fx_px = k.at<double>(0, 0);
  in.fy_px = k.at<double>(1, 1);
  in.cx_px = k.at<double>(0, 2);
  in.cy_px = k.at<double>(1, 2);
  for (int i = 0; i < 5 && i < static_cast<int>(d.total()); ++i) in.distortion[static_cast<std::size_t>(i)] = d.at<double>(i);
  in.width_px = size.width;
  in.height_px = size.height;
  in.rms_reprojection_px = rms;
  in.views = static_cast<int>(views.size());
  for (int i = 0; i < per_view.rows; ++i) result.worst_view_rms_px = std::max(result.worst_view_rms_px, per_view.at<double>(i));
  return result;
}

}  // namespace rocklab::video
