#pragma once
/// @file
/// Frames of a video and their times: a file (mp4, mkv, avi, nut; FFV1,
/// MJPG, H.264...) decoded by FFmpeg's libraries (av_decoder.h), an image
/// sequence (`frames/%06d.png`, OpenCV's image reader) or a V4L2 device
/// (live, OpenCV's VideoCapture).
///
/// Time: a file's frame k is stamped t_first + k / rate, the rate being the
/// given `fps` (the rig's or `--fps`: a slow-motion export stored at 30
/// frames/s) or else the container's nominal rate. The container's
/// timestamps (the decoded frame's presentation time)
/// only number the frames: k = round((t - t_first) x container rate), so a
/// dropped frame is a skipped number (counted), a repeated one (the same
/// number again, or a time going back) is counted and not delivered, and
/// timestamps rounded by the container (Matroska's milliseconds: up to
/// 0.5 ms at 240 frames/s) are counted (`off_grid`) and do not reach the
/// frame's time. Image sequences have no times: index / `fps`, and
/// `times_from_fps()` says so. A device's frames keep the driver's buffer
/// times (a live clock, not a grid).

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "video/video_config.h"

namespace rocklab::video {

struct FrameCounts {
  int64_t frames{};    ///< delivered
  int64_t dropped{};   ///< frame numbers skipped (from the times)
  int64_t drop_events{};  ///< places where frames were dropped
  int64_t repeated{};  ///< frames with the number of the previous one (not delivered)
  int64_t backwards{}; ///< frames whose time went back (not delivered)
  /// Frames that could not be decoded (damaged), each counted once: one
  /// with a time (a codec whose packets are frames, MJPEG) takes its frame
  /// number; one without is the first of the next gap in the numbers (not
  /// also counted dropped).
  int64_t unreadable{};
  /// The last unreadable frame's number and time, s (-1 and NaN: none, or
  /// the codec does not say which frame it was).
  int64_t last_unreadable_number{-1};
  double last_unreadable_time_s{std::numeric_limits<double>::quiet_NaN()};
  /// Frames timed index / rate because the video turned out to give no
  /// times (its second frame's time not after its first's).
  int64_t untimed{};
  /// Frames whose time OpenCV gave as 0 after frames with later times: its
  /// FFmpeg reader's time of a frame without a presentation time, as the
  /// last frames of an H.264/HEVC stream with B-frames are (the decoder
  /// gives them when flushed at the end). Numbered after the previous one
  /// (a drop among them cannot be seen).
  int64_t no_time{};
  /// Frames whose container time is off the t_first + k / rate grid by more
  /// than 1 us (rounded timestamps), and the largest such offset, s.
  int64_t off_grid{};
  double max_off_grid_s{};
  /// Frames the container announces (its frame count, or duration x rate)
  /// after the last one read: a truncated file, or a decode error that
  /// ended the read. Set at the end; 0 when the container says nothing.
  int64_t missing_at_end{};
  int64_t announced{};  ///< the container's frame count; 0: not known
  /// A file whose frame size changed: its frames from the first of the new
  /// size to its end (packets counted, not decoded), none of them tracked.
  int64_t after_size_change{};
};

class FrameReader {
 public:
  enum class Kind { kFile, kImageSequence, kDevice };
  /// Opens `spec` (a file, a printf pattern of images, or /dev/videoN with
  /// `device`). `fps` (Hz), where given, is the camera's true rate: it
  /// stamps a file's frames (the container's rate only numbers them) and
  /// times an image sequence; a device uses it only when it gives no rate.
  /// @throws std::runtime_error naming the spec when it cannot be opened,
  ///         or when it has no times and no rate was given.
  /// `colour`: which light of a colour frame becomes the 8-bit image.
  FrameReader(const std::string& spec, bool device, std::optional<double> fps,
              const ColourChoice& colour = ColourChoice{});
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  /// The next frame as 8-bit grey (or the chosen channel), its time (s) and its frame number;
  /// `gray` is valid until the next call (a file's may point into the decoder's buffer).
  /// False at the end (or when the device stops). Never throws.
  bool Next(cv::Mat& gray, double& time_s, int64_t& number);

  Kind kind() const { return kind_; }
  /// Frame rate the frames are stamped with, Hz: the given fps, else the
  /// container's nominal rate.
  double rate_hz() const { return rate_hz_; }
  /// The container's (device's) nominal rate that numbers the frames from
  /// their timestamps, Hz (= rate_hz() unless fps overrides it).
  double container_rate_hz() const { return container_rate_hz_; }
  /// Image sequences: from the start. Other videos: once they turn out to
  /// give no times (FrameCounts::untimed); read it on the reading thread.
  bool times_from_fps() const { return times_from_fps_; }
  /// Where the rate came from, for the start-up line.
  const std::string& rate_source() const { return rate_source_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const FrameCounts& counts() const { return counts_; }
  const std::string& backend() const { return backend_; }
  /// Why Next() stopped before the end (a frame of another size: the
  /// marks and intrinsics hold for the first), "frame K (...): ..."; empty
  /// at a plain end. A file's frames from there to its end are counted
  /// (FrameCounts::after_size_change) and named in it.
  const std::string& error() const { return error_; }

 private:
  struct Capture;
  std::unique_ptr<Capture> cap_;
  Kind kind_{};
  double rate_hz_{};
  double container_rate_hz_{};
  bool times_from_fps_{false};
  std::string rate_source_;
  std::string backend_;
  int width_{}, height_{};
  int64_t index_{0};            // frames read, decodable or not
  int64_t untimed_unreadable_{0};  // unreadable frames with no time since the last frame numbered
  double first_time_s_{};
  int64_t last_number_{-1};
  double last_time_s_{};
  FrameCounts counts_;
  std::string error_;
  cv::Size first_size_;
  cv::Mat raw_;  // reused: the decoded frame before the grey conversion
  void CountUnreadable(double container_time_s);
  void MoveTo(int64_t n, double container_time_s);
  ColourChoice colour_;
  cv::Matx13f bgr_weights_;  // ColourChoice::kWeights in OpenCV's B, G, R order
};

}  // namespace rocklab::video

namespace rocklab::video {

/// A FrameReader on its own thread, a few frames ahead: decoding (FFmpeg)
/// and tracking then share two cores. Threading: one decoding thread owns
/// the reader; Next() (one consumer thread) takes frames in order from a
/// ring of `depth` preallocated slots (no allocation per frame once the
/// slots have the frame size); the decoder waits while the ring is full.
/// The destructor stops and joins the thread (a blocked device read ends
/// when its frame comes).
class ReadAhead {
 public:
  /// `reader` is retained (non-owning), read only by the thread from now on.
  ReadAhead(FrameReader& reader, int depth = 4);
  ~ReadAhead();
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead& operator=(const ReadAhead&) = delete;
  /// As FrameReader::Next; `gray` stays valid until the next call. Never throws.
  bool Next(cv::Mat& gray, double& time_s, int64_t& number);
  /// Next() waiting at most `timeout_s`; sets `*timed_out` (and returns
  /// false) when no frame came in that time (a live device).
  bool Next(cv::Mat& gray, double& time_s, int64_t& number, double timeout_s, bool* timed_out);
  /// The reader's counts as of the frame Next() returned last.
  const FrameCounts& counts() const { return counts_; }
  /// After Next() returned false at the end: the reader's error() then.
  const std::string& error() const { return error_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  FrameCounts counts_;
  std::string error_;
};

}  // namespace rocklab::video
