#include "video/frame_reader.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace rocklab::video {

struct FrameReader::Capture {
  cv::VideoCapture cap;
};

FrameReader::FrameReader(const std::string& spec, bool device, std::optional<double> fallback_fps)
    : cap_(std::make_unique<Capture>()) {
  kind_ = device ? Kind::kDevice
                 : (spec.find('%') != std::string::npos ? Kind::kImageSequence : Kind::kFile);
  const int api = kind_ == Kind::kDevice ? cv::CAP_V4L2
                  : kind_ == Kind::kImageSequence ? cv::CAP_IMAGES
                                                  : cv::CAP_FFMPEG;
  bool opened = false;
  try {
    opened = cap_->cap.open(spec, api);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(spec + ": cannot be opened as a video: " + e.what());
  }
  if (!opened) {
    throw std::runtime_error(spec + ": cannot be opened as a video" +
                             std::string(kind_ == Kind::kDevice ? " device (V4L2)" : " (OpenCV's FFmpeg reader)"));
  }
  backend_ = cap_->cap.getBackendName();
  width_ = static_cast<int>(cap_->cap.get(cv::CAP_PROP_FRAME_WIDTH));
  height_ = static_cast<int>(cap_->cap.get(cv::CAP_PROP_FRAME_HEIGHT));
  const double container_fps = kind_ == Kind::kImageSequence ? 0.0 : cap_->cap.get(cv::CAP_PROP_FPS);
  if (std::isfinite(container_fps) && container_fps > 0) {
    rate_hz_ = container_fps;
    rate_source_ = kind_ == Kind::kDevice ? "the device's nominal rate" : "the container's nominal rate";
  } else if (fallback_fps) {
    rate_hz_ = *fallback_fps;
    rate_source_ = "[camera.video] fps (the video gives none)";
  } else {
    throw std::runtime_error(spec + ": the video gives no frame rate; set [camera.video] fps in the rig");
  }
  if (kind_ == Kind::kImageSequence) {
    times_from_fps_ = true;
    rate_source_ = "[camera.video] fps: an image sequence has no timestamps";
    if (!fallback_fps) {
      throw std::runtime_error(spec + ": an image sequence has no timestamps; set [camera.video] fps in the rig");
    }
  }
}

FrameReader::~FrameReader() = default;

bool FrameReader::Next(cv::Mat& gray, double& time_s, int64_t& number) {
  while (true) {
    bool ok = false;
    try {
      ok = cap_->cap.read(raw_);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok || raw_.empty()) return false;
    const int64_t index = index_++;
    double t = 0;
    if (times_from_fps_) {
      t = static_cast<double>(index) / rate_hz_;
    } else {
      t = cap_->cap.get(cv::CAP_PROP_POS_MSEC) * 1e-3;
      if (!std::isfinite(t)) {
        ++counts_.unreadable;
        continue;
      }
    }
    if (counts_.frames == 0 && last_number_ < 0) first_time_s_ = t;
    const int64_t n = std::llround((t - first_time_s_) * rate_hz_);
    if (last_number_ >= 0) {
      if (t < last_time_s_) {
        ++counts_.backwards;
        continue;
      }
      if (n == last_number_) {
        ++counts_.repeated;
        continue;
      }
      if (n > last_number_ + 1) {
        counts_.dropped += n - last_number_ - 1;
        ++counts_.drop_events;
      }
    }
    last_number_ = n;
    last_time_s_ = t;
    if (raw_.channels() == 1) {
      if (raw_.depth() == CV_8U) {
        gray = raw_;
      } else {
        raw_.convertTo(gray, CV_8U, raw_.depth() == CV_16U ? 1.0 / 257 : 1.0);
      }
    } else {
      cv::cvtColor(raw_, gray, raw_.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    }
    time_s = t;
    number = n;
    ++counts_.frames;
    return true;
  }
}

}  // namespace rocklab::video
