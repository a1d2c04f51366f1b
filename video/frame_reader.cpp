#include "video/frame_reader.h"

#include <cmath>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "video/av_decoder.h"

namespace rocklab::video {
namespace {
// A container time further than this from its frame's place on the
// t_first + k / rate grid counts as off the grid (rounded), s.
constexpr double kOffGridS = 1e-6;
// Frames announced but not read at the end beyond this many are missing.
constexpr int64_t kAnnouncedSlack = 1;
}  // namespace

// A file is decoded by FFmpeg's libraries directly (av_decoder.h); image
// sequences and devices go through OpenCV's readers.
struct FrameReader::Capture {
  cv::VideoCapture cap;
  std::unique_ptr<AvDecoder> av;
};

FrameReader::FrameReader(const std::string& spec, bool device, std::optional<double> fps, const ColourChoice& colour)
    : cap_(std::make_unique<Capture>()),
      colour_(colour),
      bgr_weights_(static_cast<float>(colour.rgb[2]), static_cast<float>(colour.rgb[1]),
                   static_cast<float>(colour.rgb[0])) {
  kind_ = device ? Kind::kDevice
                 : (spec.find('%') != std::string::npos ? Kind::kImageSequence : Kind::kFile);
  double container_fps = 0;
  if (kind_ == Kind::kFile) {
    // Grey straight from the luma plane; a colour choice needs BGR.
    cap_->av = std::make_unique<AvDecoder>(spec, colour_.kind != ColourChoice::Kind::kGrey);
    backend_ = "FFMPEG (libavcodec)";
    width_ = cap_->av->width();
    height_ = cap_->av->height();
    container_fps = cap_->av->rate_hz();
    counts_.announced = cap_->av->announced();
  } else {
    const int api = kind_ == Kind::kDevice ? cv::CAP_V4L2 : cv::CAP_IMAGES;
    bool opened = false;
    try {
      opened = cap_->cap.open(spec, api);
    } catch (const cv::Exception& e) {
      throw std::runtime_error(spec + ": cannot be opened as a video: " + e.what());
    }
    if (!opened) {
      throw std::runtime_error(spec + ": cannot be opened as a video" +
                               std::string(kind_ == Kind::kDevice ? " device (V4L2)" : " (OpenCV's image reader)"));
    }
    backend_ = cap_->cap.getBackendName();
    width_ = static_cast<int>(cap_->cap.get(cv::CAP_PROP_FRAME_WIDTH));
    height_ = static_cast<int>(cap_->cap.get(cv::CAP_PROP_FRAME_HEIGHT));
    if (kind_ == Kind::kDevice) container_fps = cap_->cap.get(cv::CAP_PROP_FPS);
  }
  const bool has_rate = std::isfinite(container_fps) && container_fps > 0;
  if (kind_ == Kind::kImageSequence) {
    if (!fps) {
      throw std::runtime_error(spec + ": an image sequence has no timestamps; set [camera.video] fps in the rig");
    }
    times_from_fps_ = true;
    rate_hz_ = container_rate_hz_ = *fps;
    rate_source_ = "[camera.video] fps: an image sequence has no timestamps";
  } else if (fps && kind_ == Kind::kFile) {
    // The camera's true rate over the container's (a slow-motion export
    // stored at 30 frames/s): the container's still numbers the frames.
    rate_hz_ = *fps;
    container_rate_hz_ = has_rate ? container_fps : *fps;
    char what[160];
    std::snprintf(what, sizeof what, "the given fps (the container says %.6g frames/s, which numbers the frames)",
                  container_rate_hz_);
    rate_source_ = has_rate ? what : "the given fps (the video gives none)";
  } else if (has_rate) {
    rate_hz_ = container_rate_hz_ = container_fps;
    rate_source_ = kind_ == Kind::kDevice ? "the device's nominal rate" : "the container's nominal rate";
  } else if (fps) {
    rate_hz_ = container_rate_hz_ = *fps;
    rate_source_ = "[camera.video] fps (the video gives none)";
  } else {
    throw std::runtime_error(spec + ": the video gives no frame rate; set [camera.video] fps in the rig");
  }
}

FrameReader::~FrameReader() = default;

bool FrameReader::Next(cv::Mat& gray, double& time_s, int64_t& number) {
  while (true) {
    bool ok = false;
    double container_time_s = 0;  // the file's (device's) time of the frame
    if (cap_->av) {
      const AvDecoder::Got got = cap_->av->Read(raw_, container_time_s);
      if (got == AvDecoder::Got::kUnreadable) {
        CountUnreadable(container_time_s);
        continue;
      }
      ok = got == AvDecoder::Got::kFrame;
    } else {
      try {
        ok = cap_->cap.read(raw_);
        if (ok && kind_ == Kind::kDevice) container_time_s = cap_->cap.get(cv::CAP_PROP_POS_MSEC) * 1e-3;
      } catch (const cv::Exception&) {
        ok = false;
      }
    }
    if (!ok || raw_.empty()) {
      // The end: frames the container announced beyond the last number
      // read are missing (one frame of slack: a duration x rate estimate).
      if (counts_.announced > 0 && last_number_ >= 0 && !times_from_fps_) {
        const int64_t after = counts_.announced - (last_number_ + 1);
        counts_.missing_at_end = after > kAnnouncedSlack ? after : 0;
      }
      return false;
    }
    // A frame of another size: image sequences and files (av_decoder.h)
    // give each frame at its own size.
    const cv::Size decoded = raw_.size();
    if (first_size_.empty()) first_size_ = decoded;
    if (decoded != first_size_) {
      // Not measured with the first size's marks and intrinsics: stop, said,
      // with the file's frames from here to its end counted.
      std::string rest;
      if (cap_->av) {
        counts_.after_size_change = 1 + cap_->av->CountRemainingPackets();
        rest = "; " + std::to_string(counts_.after_size_change) + " frame(s) from there to the end not tracked";
      }
      char msg[320];
      std::snprintf(msg, sizeof msg,
                    "frame %lld (read %lld of the file): the frame size changed from %dx%d to %dx%d px%s; the marks, "
                    "region and intrinsics hold for the first size (cut the video where it changes)",
                    static_cast<long long>(last_number_ + 1), static_cast<long long>(index_ + 1), first_size_.width,
                    first_size_.height, decoded.width, decoded.height, rest.c_str());
      error_ = msg;
      return false;
    }
    const int64_t index = index_++;
    double t = 0;        // the frame's time, s
    double stored = 0;   // its container (device) time, s
    int64_t n = index;   // its number
    if (times_from_fps_ && kind_ == Kind::kImageSequence) {
      t = stored = static_cast<double>(index) / rate_hz_;
    } else {
      stored = container_time_s;
      if (!std::isfinite(stored)) {
        ++counts_.unreadable;
        continue;
      }
      if (kind_ == Kind::kFile && !times_from_fps_ && last_number_ >= 0 && stored == 0.0 && last_time_s_ > 0) {
        // OpenCV's 0 for "no time" (B-frames flushed at the end): the next frame.
        stored = first_time_s_ + static_cast<double>(last_number_ + 1) / container_rate_hz_;
        ++counts_.no_time;
      }
      if (counts_.frames == 0 && last_number_ < 0) first_time_s_ = stored;
      if (!times_from_fps_ && index == 1 && counts_.frames == 1 && stored <= first_time_s_) {
        // No times from this video (the backend gives every frame the same):
        // index / rate from here on, counted (the source says so).
        times_from_fps_ = true;
      }
      if (times_from_fps_) {
        stored = first_time_s_ + static_cast<double>(index) / container_rate_hz_;
        t = first_time_s_ + static_cast<double>(index) / rate_hz_;
        ++counts_.untimed;
      } else {
        n = std::llround((stored - first_time_s_) * container_rate_hz_);
        if (kind_ == Kind::kDevice) {
          t = stored;  // the driver's clock: real times, not a grid
        } else {
          // The container's time only numbers the frame; its rounding stays out.
          t = first_time_s_ + static_cast<double>(n) / rate_hz_;
          const double off = std::abs(stored - (first_time_s_ + static_cast<double>(n) / container_rate_hz_));
          if (off > kOffGridS) {
            ++counts_.off_grid;
            counts_.max_off_grid_s = std::max(counts_.max_off_grid_s, off);
          }
        }
      }
    }
    if (last_number_ >= 0) {
      if (stored < last_time_s_) {
        ++counts_.backwards;
        continue;
      }
      if (n == last_number_) {
        ++counts_.repeated;
        continue;
      }
    }
    MoveTo(n, stored);
    if (raw_.channels() == 1) {
      if (raw_.depth() == CV_8U) {
        gray = raw_;
      } else {
        raw_.convertTo(gray, CV_8U, raw_.depth() == CV_16U ? 1.0 / 257 : 1.0);
      }
    } else if (colour_.kind == ColourChoice::Kind::kChannel) {
      cv::extractChannel(raw_, gray, 2 - colour_.channel);  // OpenCV's order is B, G, R
    } else if (colour_.kind == ColourChoice::Kind::kWeights) {
      cv::Mat bgr = raw_;
      if (raw_.channels() == 4) cv::cvtColor(raw_, bgr, cv::COLOR_BGRA2BGR);
      cv::transform(bgr, gray, bgr_weights_);  // saturates to 0..255
    } else {
      cv::cvtColor(raw_, gray, raw_.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    }
    time_s = t;
    number = n;
    ++counts_.frames;
    return true;
  }
}

// Frame n (a frame given, or one refused at its time) after the last
// numbered one: the frames between are dropped, less those refused with no
// time (the first of the gap, not drops).
void FrameReader::MoveTo(int64_t n, double container_time_s) {
  if (last_number_ >= 0) {
    const int64_t gap = n - last_number_ - 1;
    const int64_t lost = gap - std::min(std::max(gap, int64_t{0}), untimed_unreadable_);
    if (lost > 0) {
      counts_.dropped += lost;
      ++counts_.drop_events;
    }
  }
  untimed_unreadable_ = 0;
  last_number_ = n;
  last_time_s_ = container_time_s;
}

// A frame the decoder refused: counted once, at its number where its time
// says it (the next frame's number then follows it, no drop), else as the
// first frame of the next gap.
void FrameReader::CountUnreadable(double container_time_s) {
  ++counts_.unreadable;
  ++index_;  // a frame of the file: an untimed video's later frames keep their index
  counts_.last_unreadable_number = -1;
  counts_.last_unreadable_time_s = std::numeric_limits<double>::quiet_NaN();
  if (times_from_fps_ || !std::isfinite(container_time_s)) {
    ++untimed_unreadable_;
    return;
  }
  if (last_number_ < 0) first_time_s_ = container_time_s;  // the file's first frame, damaged
  const int64_t n = std::llround((container_time_s - first_time_s_) * container_rate_hz_);
  if (last_number_ >= 0 && (n <= last_number_ || container_time_s < last_time_s_)) return;  // not a new place
  MoveTo(n, container_time_s);
  counts_.last_unreadable_number = n;
  counts_.last_unreadable_time_s = first_time_s_ + static_cast<double>(n) / rate_hz_;
}

}  // namespace rocklab::video

namespace rocklab::video {

struct ReadAhead::Impl {
  struct Slot {
    cv::Mat gray;
    double time_s{};
    int64_t number{};
    FrameCounts counts;
    std::string error;
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
      if (!ok) s.error = reader->error();
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
  if (s.end) {
    error_ = s.error;
    return false;
  }  // stays filled: every later call ends too
  m.holding = true;
  gray = s.gray;
  time_s = s.time_s;
  number = s.number;
  return true;
}

}  // namespace rocklab::video
