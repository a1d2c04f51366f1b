#include "video/frame_reader.h"

#include <cmath>
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

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
    if (!times_from_fps_ && index == 1 && counts_.frames == 1 && t <= first_time_s_) {
      // No times from this video (the backend gives every frame the same):
      // index / rate from here on, counted (the source says so).
      times_from_fps_ = true;
    }
    if (times_from_fps_ && kind_ != Kind::kImageSequence) {
      t = first_time_s_ + static_cast<double>(index) / rate_hz_;
      ++counts_.untimed;
    }
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

namespace rocklab::video {

struct ReadAhead::Impl {
  struct Slot {
    cv::Mat gray;
    double time_s{};
    int64_t number{};
    FrameCounts counts;
    bool end{false};
  };
  FrameReader* reader{};
  std::vector<Slot> slots;
  std::size_t head{0}, tail{0}, filled{0};  // producer writes slots[head], consumer reads slots[tail]
  bool holding{false};                      // the consumer still uses slots[tail]
  bool stop{false};
  std::mutex mutex;
  std::condition_variable changed;
  std::thread thread;

  void Run() {
    cv::Mat gray;
    double t = 0;
    int64_t n = 0;
    while (true) {
      const bool ok = reader->Next(gray, t, n);
      std::unique_lock<std::mutex> lock(mutex);
      // A full ring: wait for the consumer (the slot it holds counts as full).
      changed.wait(lock, [&] { return stop || filled < slots.size(); });
      if (stop) return;
      Slot& s = slots[head];
      lock.unlock();
      if (ok) gray.copyTo(s.gray);  // reuses the slot's buffer at the same size
      s.time_s = t;
      s.number = n;
      s.counts = reader->counts();
      s.end = !ok;
      lock.lock();
      head = (head + 1) % slots.size();
      ++filled;
      changed.notify_all();
      if (!ok) return;
    }
  }
};

ReadAhead::ReadAhead(FrameReader& reader, int depth) : impl_(std::make_unique<Impl>()) {
  impl_->reader = &reader;
  impl_->slots.resize(static_cast<std::size_t>(std::max(depth, 1)) + 1);
  impl_->thread = std::thread([this] { impl_->Run(); });
}

ReadAhead::~ReadAhead() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stop = true;
  }
  impl_->changed.notify_all();
  impl_->thread.join();
}

bool ReadAhead::Next(cv::Mat& gray, double& time_s, int64_t& number) {
  return Next(gray, time_s, number, -1.0, nullptr);
}

bool ReadAhead::Next(cv::Mat& gray, double& time_s, int64_t& number, double timeout_s, bool* timed_out) {
  Impl& m = *impl_;
  if (timed_out != nullptr) *timed_out = false;
  std::unique_lock<std::mutex> lock(m.mutex);
  if (m.holding) {  // the previous frame is given back
    m.tail = (m.tail + 1) % m.slots.size();
    --m.filled;
    m.holding = false;
    m.changed.notify_all();
  }
  if (timeout_s < 0) {
    m.changed.wait(lock, [&] { return m.filled > 0; });
  } else if (!m.changed.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return m.filled > 0; })) {
    if (timed_out != nullptr) *timed_out = true;
    return false;
  }
  const Impl::Slot& s = m.slots[m.tail];
  counts_ = s.counts;
  if (s.end) return false;  // stays filled: every later call ends too
  m.holding = true;
  gray = s.gray;
  time_s = s.time_s;
  number = s.number;
  return true;
}

}  // namespace rocklab::video
