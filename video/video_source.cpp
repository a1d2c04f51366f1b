#include "video/video_source.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "common/logger_clock.h"
#include "daq/rig_config.h"
#include "video/board_marks.h"
#include "video/plane_map.h"
#include "video/video_config.h"
#include "common/units.h"

namespace rocklab::video {
namespace {

using common::kNaN;
// Drop events reported one by one up to this many, then only counted.
constexpr int64_t kShownDrops = 20;
// A device's frames are waited for this long before Next() says kIdle, s.
constexpr double kIdleWaitS = 0.1;

class VideoSource : public daq::Source {
 public:
  VideoSource(const std::string& spec, bool device, const daq::SourceOptions& options,
              std::optional<double> fps_override)
      : path_(device ? "v4l2:" + spec : spec),
        device_(device),
        on_problem_(options.on_problem),
        stop_(options.stop),
        idle_timeout_s_(options.idle_timeout_s),
        config_(ResolveBoardMarks(WithFps(LoadVideoConfig(*options.rig), fps_override), device ? "" : spec)),
        map_(config_.intrinsics, config_.marks, config_.rig_path),
        reader_(spec, device, config_.fps, config_.colour),
        detector_(Options(config_)),
        tracker_(config_, map_) {
    for (const VideoLed& led : config_.leds) {
      names_.push_back(led.x_channel->name);
      names_.push_back(led.z_channel->name);
    }
    for (const VideoLed& led : config_.leds) {
      const std::string base = config_.camera + "_" + led.name;
      names_.push_back(base + "_area_px");
      names_.push_back(base + "_peak");
      names_.push_back(base + "_flags");
    }
    for (const VideoLed& led : config_.leds) {
      const std::string base = config_.camera + "_" + led.name;
      names_.push_back(base + "_sigma_x_m");
      names_.push_back(base + "_sigma_z_m");
    }
    if (config_.sync.by_table) {
      stats_.sync_table = true;
      stats_.sync_channel = config_.sync.channel;
    } else if (config_.sync.present) {
      names_.push_back(config_.camera + "_sync_level");
      stats_.sync_led = true;
      stats_.sync_channel = config_.sync.channel;
      stats_.sync_row_delay_s =
          reader_.height() > 0 ? config_.readout_s * config_.sync.v_px / reader_.height() : 0.0;
      if (reader_.width() > 0 && (config_.sync.u_px >= reader_.width() || config_.sync.v_px >= reader_.height())) {
        throw std::runtime_error(config_.rig_path + ":" + std::to_string(config_.sync.line) +
                                 ": key 'camera.video.sync_led_px' is outside the " + std::to_string(reader_.width()) +
                                 "x" + std::to_string(reader_.height()) + " px frames of " + path_);
      }
    }
    stats_.mark_rms_m = map_.mark_rms_m();
    stats_.mark_rms_px = map_.mark_rms_px();
    stats_.m_per_px = map_.scale_m_per_px();
    stats_.gate_m = tracker_.gate_m();
    stats_.rate_hz = reader_.rate_hz();
    reader_rate_ = reader_.rate_hz();
    stats_.rate_source = reader_.rate_source();
    stats_.times_from_fps = reader_.times_from_fps();
    stats_.width_px = reader_.width();
    stats_.height_px = reader_.height();
    stats_.exposure_s = config_.exposure_s;
    stats_.device = device;
    stats_.readout_s = config_.readout_s;
    tracker_.SetRowTime(config_.readout_s, reader_.height());
    if (config_.intrinsics && config_.intrinsics->width_px > 0 && reader_.width() > 0 &&
        (config_.intrinsics->width_px != reader_.width() || config_.intrinsics->height_px != reader_.height())) {
      throw std::runtime_error(path_ + ": frames are " + std::to_string(reader_.width()) + "x" +
                               std::to_string(reader_.height()) + " px but the intrinsics of " +
                               config_.rig_path + " hold for " + std::to_string(config_.intrinsics->width_px) +
                               "x" + std::to_string(config_.intrinsics->height_px));
    }
    auto log = common::NamedLogger("video");
    log->info("{}: {}x{} px, {:.6g} frames/s from {}{}; exposure {:.3g} ms, rolling-shutter readout {:.3g} ms; "
              "camera '{}', {} LEDs found in the {} light; marks fit to {:.3g} mm ({:.3g} px), {:.3g} mm/px, gate {:.3g} mm",
              path_, reader_.width(), reader_.height(), reader_.rate_hz(), reader_.rate_source(),
              reader_.times_from_fps() ? " (frame times are index / fps)"
              : device_                ? ", frame times from the driver"
                                       : ", frame k at t0 + k / rate (the container's times number the frames)",
              1e3 * config_.exposure_s, 1e3 * config_.readout_s,
              config_.camera, config_.leds.size(), config_.colour.Describe(), 1e3 * map_.mark_rms_m(), map_.mark_rms_px(),
              1e3 * map_.scale_m_per_px(), 1e3 * tracker_.gate_m());
    if (std::abs(reader_.rate_hz() - options.rig->sample_rate_hz) > 1e-3 * reader_.rate_hz()) {
      Report(0, "the video's " + std::to_string(reader_.rate_hz()) + " frames/s differ from the rig's sample_rate_hz " +
                    std::to_string(options.rig->sample_rate_hz) +
                    " (the differentiators' windows are set from the rig's)");
      ++stats_src_.warnings;
    }
    samples_.reserve(config_.leds.size());
    // Last: from here on only its thread touches reader_.
    read_ahead_ = std::make_unique<ReadAhead>(reader_);
  }

  const std::vector<std::string>& channel_names() const override { return names_; }
  double sample_rate_hz() const override { return reader_rate_; }
  const daq::SourceStats& stats() const override { return stats_src_; }
  const std::string& path() const override { return path_; }
  bool live() const override { return device_; }
  const VideoStats& video_stats() const { return stats_; }
  void Observe(std::function<void(const FrameView&)> observer) {
    observer_ = std::move(observer);
    led_names_.clear();
    for (const VideoLed& led : config_.leds) led_names_.push_back(led.name);
  }
  std::string summary() const override {
    return std::to_string(stats_.frames.frames) + " video frames " + VideoSummary(stats_);
  }

  daq::ReadStatus Next(daq::Frame& frame) override {
    if (!error_.empty()) return daq::ReadStatus::kError;
    double t = 0;
    int64_t number = 0;
    const int64_t dropped_before = read_ahead_->counts().dropped;
    bool idle = false;
    // A device is waited on 0.1 s at a time (the DAQ's live contract: kIdle).
    if (!read_ahead_->Next(gray_, t, number, device_ ? kIdleWaitS : -1.0, &idle)) {
      Sync();
      if (!idle) SayUnreadable(stats_.frames.frames + 1, "after the last frame");
      if (!idle && !read_ahead_->error().empty()) {
        error_ = path_ + ":" + std::to_string(stats_.frames.frames + 1) + ": " + read_ahead_->error();
        Report(stats_.frames.frames + 1, read_ahead_->error());
        return daq::ReadStatus::kError;
      }
      if (!idle && stats_.frames.missing_at_end > 0 && !end_said_) {
        end_said_ = true;
        ++stats_src_.warnings;
        Report(stats_.frames.frames + 1,
               "the container announces " + std::to_string(stats_.frames.announced) + " frames but the read ended " +
                   std::to_string(stats_.frames.missing_at_end) +
                   " frame(s) early (a truncated file, or a decode error that ended it)");
      }
      if (idle) {
        const double quiet_s = std::chrono::duration<double>(Clock::now() - last_frame_).count();
        const bool stopped = stop_ != nullptr && stop_->load();
        if (stopped || (idle_timeout_s_ > 0 && quiet_s > idle_timeout_s_)) return daq::ReadStatus::kEnd;
        return daq::ReadStatus::kIdle;
      }
      return daq::ReadStatus::kEnd;
    }
    last_frame_ = Clock::now();
    if (read_ahead_->counts().untimed > 0 && !stats_.times_from_fps) {
      stats_.times_from_fps = true;
      stats_.rate_source += "; the video gives no frame times: index / rate";
      ++stats_src_.warnings;
      Report(number, "the video gives no frame times: frames are timed index / " + std::to_string(reader_rate_) +
                         " Hz and drops cannot be seen");
    }
    if (read_ahead_->counts().off_grid > 0 && !off_grid_said_) {
      off_grid_said_ = true;
      ++stats_src_.warnings;
      Report(number, "the container's timestamps are off the 1/rate grid (rounded, as Matroska's milliseconds): "
                     "frames are stamped t0 + k / " + std::to_string(reader_rate_) +
                         " Hz, the container's times only find drops and repeats");
    }
    if (read_ahead_->counts().no_time > 0 && !no_time_said_) {
      no_time_said_ = true;
      ++stats_src_.warnings;
      Report(number, "frames without a time (OpenCV gives 0: B-frames the decoder hands over at the end): each "
                     "numbered after the previous one, so a drop among them cannot be seen");
    }
    SayUnreadable(number, "before this one");
    const int64_t dropped = read_ahead_->counts().dropped - dropped_before;
    if (dropped > 0) {
      ++stats_src_.warnings;
      if (read_ahead_->counts().drop_events <= kShownDrops) {
        Report(number, std::to_string(dropped) + " frame(s) dropped before this one (from the frame times)");
      }
    }
    // The middle of the exposure (the stored time is its start).
    t += 0.5 * config_.exposure_s;
    detector_.Detect(gray_, blobs_);
    const int64_t fits_before = tracker_.counts().fits;
    tracker_.Track(blobs_, t, samples_);
    if (observer_) {
      FrameView view{&gray_, &blobs_, &samples_, &led_names_, t, number,
                     tracker_.counts().fits > fits_before ? tracker_.theta() : kNaN};
      observer_(view);
    }
    ++stats_src_.rows;
    if (!CheckLit(t, number)) return daq::ReadStatus::kError;
    ReportOutliers(number);
    frame.seq = number;
    frame.time_s = t;
    frame.line = number + 1;
    frame.comment.clear();
    frame.values.resize(names_.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const VideoLed& led = config_.leds[i];
      const LedSample& s = samples_[i];
      frame.values[k++] = (s.x_m - led.x_channel->offset) / led.x_channel->gain;
      frame.values[k++] = (s.z_m - led.z_channel->offset) / led.z_channel->gain;
    }
    for (const LedSample& s : samples_) {
      frame.values[k++] = s.area_px > 0 ? s.area_px : kNaN;
      frame.values[k++] = s.area_px > 0 ? s.peak : kNaN;
      frame.values[k++] = static_cast<double>(s.flags);
    }
    for (const LedSample& s : samples_) {
      frame.values[k++] = s.sigma_x_m;
      frame.values[k++] = s.sigma_z_m;
    }
    if (config_.sync.present && !config_.sync.by_table) frame.values[k++] = SyncLevel();
    Sync();
    return daq::ReadStatus::kFrame;
  }

 private:
  static DetectorOptions Options(const VideoConfig& c) {
    DetectorOptions o;
    o.roi_px = c.roi_px;
    o.threshold = c.threshold;
    o.min_area_px = c.min_area_px;
    o.max_area_px = c.max_area_px;
    o.saturation = c.saturation;
    return o;
  }
  static VideoConfig WithFps(VideoConfig c, std::optional<double> fps) {
    if (fps) c.fps = fps;
    return c;
  }
  // The sync LED's light: the mean level of the window around it (clipped
  // to the frame), linear in the time it was on during the exposure while
  // no pixel of it is clipped (docs/video.md, Sync with the DAQ).
  double SyncLevel() const {
    const int r = config_.sync.radius_px;
    const int u = static_cast<int>(std::lround(config_.sync.u_px)), v = static_cast<int>(std::lround(config_.sync.v_px));
    const int x0 = std::max(0, u - r), x1 = std::min(gray_.cols - 1, u + r);
    const int y0 = std::max(0, v - r), y1 = std::min(gray_.rows - 1, v + r);
    if (x1 < x0 || y1 < y0) return kNaN;
    double sum = 0;
    for (int y = y0; y <= y1; ++y) {
      const unsigned char* row = gray_.ptr<unsigned char>(y);
      for (int x = x0; x <= x1; ++x) sum += row[x];
    }
    return sum / ((x1 - x0 + 1) * (y1 - y0 + 1));
  }
  // No LED identified for longer than max_dark_s is an error naming the frame.
  bool CheckLit(double t, int64_t number) {
    bool lit = false;
    for (const LedSample& s : samples_) lit = lit || std::isfinite(s.x_m);
    if (!have_lit_time_ || lit) {
      last_lit_s_ = t;
      have_lit_time_ = true;
      return true;
    }
    if (config_.max_dark_s <= 0 || t - last_lit_s_ <= config_.max_dark_s) return true;
    char msg[256];
    std::snprintf(msg, sizeof msg,
                  "frame %lld (t = %.6f s): no LED identified for %.3f s, more than [camera.video] max_dark_s = "
                  "%g s of %s (set it to 0 to read on)",
                  static_cast<long long>(number), t, t - last_lit_s_, config_.max_dark_s, config_.rig_path.c_str());
    error_ = path_ + ":" + std::to_string(number + 1) + ": " + msg;
    Report(number + 1, msg);
    Sync();
    return false;
  }
  // One message per episode of an LED's blob rejected by its statistics.
  void ReportOutliers(int64_t number) {
    outlier_now_.resize(samples_.size(), false);
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const bool now = (samples_[i].flags & kLedOutlier) != 0;
      if (now && !outlier_now_[i]) {
        ++stats_src_.warnings;
        if (++outlier_episodes_ <= kShownDrops) {
          Report(number + 1, "LED " + config_.leds[i].name + ": blob of " + std::to_string(samples_[i].area_px) +
                                 " px departs from its running area and light (a glint or reflection merged "
                                 "with it?): rejected from here on until it matches again");
        }
      }
      outlier_now_[i] = now;
    }
  }
  // Frames the decoder refused since the last said: counted (a warning),
  // the last one named with its number and time (the first kShownDrops times).
  void SayUnreadable(int64_t line, const char* where) {
    const FrameCounts& c = read_ahead_->counts();
    const int64_t n = c.unreadable - unreadable_said_;
    if (n <= 0) return;
    unreadable_said_ = c.unreadable;
    ++stats_src_.warnings;
    if (++unreadable_events_ > kShownDrops) return;
    std::string which;
    if (c.last_unreadable_number >= 0) {
      char at[96];
      std::snprintf(at, sizeof at, " (the last: frame %lld, t = %.6f s)", static_cast<long long>(c.last_unreadable_number),
                    c.last_unreadable_time_s);
      which = at;
    }
    Report(line, std::to_string(n) + " frame(s) " + where + " could not be decoded (damaged)" + which +
                     ": counted unreadable, not tracked");
  }
  void Report(int64_t line, const std::string& message) {
    if (on_problem_) on_problem_(daq::Problem{daq::Location{&path_, line}, message});
  }
  void Sync() {
    stats_.frames = read_ahead_->counts();
    stats_.detector = detector_.counts();
    stats_.track = tracker_.counts();
    // Frames not delivered are the source's bad rows.
    stats_src_.bad_rows = stats_.frames.unreadable + stats_.frames.repeated + stats_.frames.backwards;
  }

  using Clock = std::chrono::steady_clock;
  std::string path_;
  bool device_;
  daq::ProblemCallback on_problem_;
  const std::atomic<bool>* stop_;  // non-owning, may be null (SourceOptions::stop)
  double idle_timeout_s_;
  Clock::time_point last_frame_{Clock::now()};
  VideoConfig config_;
  PlaneMap map_;
  FrameReader reader_;  // read only by read_ahead_'s thread once that exists
  LedDetector detector_;
  LedTracker tracker_;
  std::vector<std::string> names_;
  daq::SourceStats stats_src_;
  VideoStats stats_;
  double reader_rate_{};  // reader_.rate_hz(), read before read_ahead_ owns the reader
  // Decoding on its own thread, tracking on the caller's; declared after
  // reader_, so destroyed (its thread joined) before it.
  std::unique_ptr<ReadAhead> read_ahead_;
  bool off_grid_said_{false};
  bool no_time_said_{false};
  bool end_said_{false};
  int64_t unreadable_said_{0};   // unreadable frames said so far
  int64_t unreadable_events_{0};
  bool have_lit_time_{false};
  double last_lit_s_{};
  std::vector<bool> outlier_now_;
  int64_t outlier_episodes_{0};
  cv::Mat gray_;
  std::vector<Blob> blobs_;
  std::vector<LedSample> samples_;
  std::function<void(const FrameView&)> observer_;
  std::vector<std::string> led_names_;
};

// How the frames were timed, for track's summary.
std::string FrameTiming(const VideoStats& v) {
  char b[200];
  if (v.device) {
    std::snprintf(b, sizeof b, "frame times from the driver");
  } else if (v.times_from_fps) {
    std::snprintf(b, sizeof b, "frame times index / %.6g Hz (the video gives none)", v.rate_hz);
  } else if (v.frames.off_grid > 0) {
    std::snprintf(b, sizeof b,
                  "frame k at t0 + k / %.6g Hz: %lld container times rounded (off that grid by up to %.3g ms), "
                  "used only to find drops and repeats",
                  v.rate_hz, static_cast<long long>(v.frames.off_grid), 1e3 * v.frames.max_off_grid_s);
  } else {
    std::snprintf(b, sizeof b, "frame k at t0 + k / %.6g Hz (the container's times on that grid)", v.rate_hz);
  }
  return b;
}

}  // namespace

std::string VideoSummary(const VideoStats& v) {
  char b[1400];
  std::snprintf(b, sizeof b,
                "(%dx%d px, %.6g frames/s from %s); %lld dropped in %lld places, "
                "%lld repeated, %lld out of order, %lld given no time (numbered after the previous), %lld unreadable, "
                "%lld missing at the end; LED samples: %lld missing "
                "(%lld occlusions), %lld merged, %lld ambiguous, %lld inconsistent, %lld saturated; "
                "%lld stray blobs (reflections); rigid fits in %lld frames; marks fit to %.3g mm (%.3g px), "
                "%.3g mm/px; %lld LED samples rejected as outliers of their blob statistics (a glint merged), "
                "%lld statistics restarted, %lld drops from the rigid fit held; "
                "%s; times mid-exposure (exposure %.3g ms), rolling-shutter readout %.3g ms",
                v.width_px, v.height_px, v.rate_hz, v.rate_source.c_str(), static_cast<long long>(v.frames.dropped),
                static_cast<long long>(v.frames.drop_events), static_cast<long long>(v.frames.repeated),
                static_cast<long long>(v.frames.backwards), static_cast<long long>(v.frames.no_time),
                static_cast<long long>(v.frames.unreadable),
                static_cast<long long>(v.frames.missing_at_end), static_cast<long long>(v.track.missing_samples),
                static_cast<long long>(v.track.occlusions), static_cast<long long>(v.track.merged),
                static_cast<long long>(v.track.ambiguous), static_cast<long long>(v.track.inconsistent),
                static_cast<long long>(v.track.saturated), static_cast<long long>(v.track.reflections),
                static_cast<long long>(v.track.fits), 1e3 * v.mark_rms_m, v.mark_rms_px, 1e3 * v.m_per_px,
                static_cast<long long>(v.track.outliers), static_cast<long long>(v.track.stat_restarts),
                static_cast<long long>(v.track.held_drops), FrameTiming(v).c_str(), 1e3 * v.exposure_s,
                1e3 * v.readout_s);
  return b;
}

namespace {

std::unique_ptr<daq::Source> OpenVideoFile(const std::string& spec, const daq::SourceOptions& options) {
  return OpenVideoSource(spec, false, options);
}
std::unique_ptr<daq::Source> OpenVideoDevice(const std::string& spec, const daq::SourceOptions& options) {
  return OpenVideoSource(spec, true, options);
}

}  // namespace

std::unique_ptr<daq::Source> OpenVideoSource(const std::string& spec, bool device,
                                             const daq::SourceOptions& options) {
  return OpenVideoSource(spec, device, options, std::nullopt);
}

std::unique_ptr<daq::Source> OpenVideoSource(const std::string& spec, bool device,
                                             const daq::SourceOptions& options, std::optional<double> fps) {
  if (options.rig == nullptr) throw std::invalid_argument(spec + ": a video input needs the rig (--rig)");
  if (spec.empty()) throw std::invalid_argument("video: no file (expected video:FILE or v4l2:/dev/videoN)");
  return std::make_unique<VideoSource>(spec, device, options, fps);
}

const VideoStats* VideoStatsOf(const daq::Source& source) {
  const auto* v = dynamic_cast<const VideoSource*>(&source);
  return v != nullptr ? &v->video_stats() : nullptr;
}

void ObserveFrames(daq::Source& source, std::function<void(const FrameView&)> observer) {
  auto* v = dynamic_cast<VideoSource*>(&source);
  if (v == nullptr) throw std::invalid_argument("ObserveFrames: not a video source");
  v->Observe(std::move(observer));
}

void RegisterSources() {
  daq::RegisterSourceForm("video:", &OpenVideoFile);
  daq::RegisterSourceForm("v4l2:", &OpenVideoDevice);
}

}  // namespace rocklab::video
