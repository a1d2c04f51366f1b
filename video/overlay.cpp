#include "video/overlay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "common/atomic_file.h"

namespace rocklab::video {
namespace {

const cv::Scalar kOverlayGood(60, 220, 60);       // B, G, R
const cv::Scalar kOverlayRejected(0, 150, 255);
const cv::Scalar kOverlayStray(40, 40, 255);
const cv::Scalar kOverlayText(255, 255, 255);

// Why an LED was not measured, in a word.
const char* OverlayReason(uint32_t flags) {
  if (flags & kLedMerged) return "merged";
  if (flags & kLedAmbiguous) return "ambiguous";
  if (flags & kLedInconsistent) return "inconsistent";
  if (flags & kLedOutlier) return "outlier";
  return "";
}

std::string Extension(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return path.substr(dot);
}

}  // namespace

struct OverlayWriter::Impl {
  common::AtomicFile file;
  cv::VideoWriter writer;
  cv::Size size;
  cv::Mat canvas;
  Impl(const std::string& path, const std::string& extension) : file(path, extension) {}
};

OverlayWriter::OverlayWriter(const std::string& path, double fps, int width, int height) {
  const std::string ext = Extension(path);
  if (ext != ".mkv" && ext != ".avi") {
    throw std::runtime_error(path + ": an overlay is written as .mkv or .avi (MJPEG)");
  }
  impl_ = std::make_unique<Impl>(path, ext);
  impl_->size = cv::Size(width, height);
  // MJPEG: every frame stands alone (scrubbing), and OpenCV's FFmpeg writer
  // on Debian writes it into both containers.
  if (!impl_->writer.open(impl_->file.path(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps,
                          impl_->size, true)) {
    throw std::runtime_error(path + ": OpenCV cannot write an MJPEG video there");
  }
}

OverlayWriter::~OverlayWriter() = default;

void OverlayWriter::Write(const FrameView& v) {
  Impl& m = *impl_;
  if (v.gray == nullptr || v.gray->size() != m.size) return;
  cv::cvtColor(*v.gray, m.canvas, cv::COLOR_GRAY2BGR);
  const double scale = std::max(0.35, m.size.height / 720.0);
  const int thick = std::max(1, static_cast<int>(std::lround(m.size.height / 480.0)));
  const int radius = std::max(6, m.size.height / 60);
  // Blobs no LED took.
  for (const Blob& b : *v.blobs) {
    bool taken = false;
    for (const LedSample& s : *v.samples) taken = taken || (s.u_px == b.u_px && s.v_px == b.v_px);
    if (taken) continue;
    const cv::Point p(static_cast<int>(std::lround(b.u_px)), static_cast<int>(std::lround(b.v_px)));
    cv::drawMarker(m.canvas, p, kOverlayStray, cv::MARKER_TILTED_CROSS, radius, thick);
  }
  // The LEDs: identified, or their blob rejected and why.
  for (std::size_t i = 0; i < v.samples->size(); ++i) {
    const LedSample& s = (*v.samples)[i];
    if (!std::isfinite(s.u_px)) continue;
    const bool good = std::isfinite(s.x_m);
    const cv::Scalar colour = good ? kOverlayGood : kOverlayRejected;
    const cv::Point p(static_cast<int>(std::lround(s.u_px)), static_cast<int>(std::lround(s.v_px)));
    cv::circle(m.canvas, p, radius, colour, thick, cv::LINE_AA);
    std::string label = (*v.led_names)[i];
    if (!good) label += std::string(" ") + OverlayReason(s.flags);
    cv::putText(m.canvas, label, p + cv::Point(radius + 2, -radius), cv::FONT_HERSHEY_SIMPLEX, scale, colour, thick,
                cv::LINE_AA);
  }
  char text[160];
  if (std::isfinite(v.theta_rad)) {
    std::snprintf(text, sizeof text, "frame %lld  t %.4f s  theta %+.5f rad", static_cast<long long>(v.number),
                  v.time_s, v.theta_rad);
  } else {
    std::snprintf(text, sizeof text, "frame %lld  t %.4f s  theta: no fit", static_cast<long long>(v.number),
                  v.time_s);
  }
  cv::putText(m.canvas, text, cv::Point(4, static_cast<int>(20 * scale / 0.5)), cv::FONT_HERSHEY_SIMPLEX, scale,
              kOverlayText, thick, cv::LINE_AA);
  m.writer.write(m.canvas);
  ++frames_;
}

void OverlayWriter::Commit() {
  impl_->writer.release();
  impl_->file.Commit();
}

}  // namespace rocklab::video
