#pragma once
/// @file
/// Frames of a video and their times, through OpenCV's VideoCapture: a file
/// (FFmpeg backend: mp4, mkv, avi; FFV1, MJPG, H.264...), an image sequence
/// (`frames/%06d.png`, OpenCV's image reader) or a V4L2 device (live).
///
/// Time: each frame's from the container's timestamps (CAP_PROP_POS_MSEC,
/// the decoded frame's presentation time) or, live, the driver's buffer
/// time; never from the frame's index. Image sequences have no times: there
/// the rig's `[camera.video] fps` is used and `times_from_fps()` says so.
/// The frame number is round((t - t_first) x nominal rate): a dropped
/// frame is a skipped number (counted), a repeated one (the same number
/// again, or a time going back) is counted and not delivered.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace rocklab::video {

struct FrameCounts {
  int64_t frames{};    ///< delivered
  int64_t dropped{};   ///< frame numbers skipped (from the times)
  int64_t drop_events{};  ///< places where frames were dropped
  int64_t repeated{};  ///< frames with the number of the previous one (not delivered)
  int64_t backwards{}; ///< frames whose time went back (not delivered)
  int64_t unreadable{};  ///< frames that could not be decoded
  /// Frames timed index / rate because the video turned out to give no
  /// times (its second frame's time not after its first's).
  int64_t untimed{};
};

class FrameReader {
 public:
  enum class Kind { kFile, kImageSequence, kDevice };
  /// Opens `spec` (a file, a printf pattern of images, or /dev/videoN with
  /// `device`). `fallback_fps` (Hz) is used where the video has no times
  /// or no nominal rate.
  /// @throws std::runtime_error naming the spec when it cannot be opened,
  ///         or when it has no times and no fallback rate was given.
  FrameReader(const std::string& spec, bool device, std::optional<double> fallback_fps);
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  /// The next frame as 8-bit grey, its time (s) and its frame number.
  /// False at the end (or when the device stops). Never throws.
  bool Next(cv::Mat& gray, double& time_s, int64_t& number);

  Kind kind() const { return kind_; }
  /// Nominal frame rate, Hz: the container's, else the fallback.
  double rate_hz() const { return rate_hz_; }
  /// Image sequences: from the start. Other videos: once they turn out to
  /// give no times (FrameCounts::untimed); read it on the reading thread.
  bool times_from_fps() const { return times_from_fps_; }
  /// Where the rate came from, for the start-up line.
  const std::string& rate_source() const { return rate_source_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const FrameCounts& counts() const { return counts_; }
  const std::string& backend() const { return backend_; }

 private:
  struct Capture;
  std::unique_ptr<Capture> cap_;
  Kind kind_{};
  double rate_hz_{};
  bool times_from_fps_{false};
  std::string rate_source_;
  std::string backend_;
  int width_{}, height_{};
  int64_t index_{0};            // frames read, decodable or not
  double first_time_s_{};
  int64_t last_number_{-1};
  double last_time_s_{};
  FrameCounts counts_;
  cv::Mat raw_;  // reused: the decoded frame before the grey conversion
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

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  FrameCounts counts_;
};

}  // namespace rocklab::video
