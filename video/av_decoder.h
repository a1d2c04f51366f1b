#pragma once
/// @file
/// A video file's frames decoded with FFmpeg's libraries directly
/// (libavformat, libavcodec, libswscale), for FrameReader (frame_reader.h).
///
/// Why not OpenCV's FFmpeg reader: it converts every frame to BGR (swscale)
/// before the tracker takes it back to grey, about a third of the decoding
/// time at 720p MJPEG (docs/performance.md), and it keeps handing back
/// frames of the first size when the stream's size changes (their content
/// not the scene). Here a grey frame is the decoded luma plane as it is (or
/// limited-range luma stretched to 0..255, as swscale's BGR would have it);
/// only a colour choice, or a frame with no 8-bit luma plane, goes through
/// swscale to BGR. Each frame comes at its own size.
///
/// Times are the OpenCV reader's (CAP_PROP_POS_MSEC): the frame's best-effort
/// presentation time less the stream's start time; 0 when the frame has
/// none. Except in AVI: its demuxer times a frame by counting the chunks it
/// has read, so a chunk lost to damage (zeros over it) would stamp every
/// later frame early; here a packet found in the file's index (idx1, by its
/// place in the file) takes the index's frame number. The rate and the
/// announced frame count are OpenCV's CAP_PROP_FPS and CAP_PROP_FRAME_COUNT.
///
/// A frame the decoder refuses is returned as unreadable, never skipped in
/// silence: with its packet's time where the codec's frames stand alone
/// (MJPEG, FFV1: packet = frame), else with no time. MJPEG is decoded
/// strictly (AV_EF_EXPLODE): a damaged JPEG is refused, not concealed into
/// a frame whose LEDs would be wrong. Threading: one thread at a time.

#include <cstdint>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

namespace rocklab::video {

class AvDecoder {
 public:
  /// Opens `path`'s best video stream. `bgr`: frames as 8-bit BGR (a colour
  /// choice); else 8-bit grey where the frame has an 8-bit luma plane.
  /// @throws std::runtime_error naming the file when it cannot be opened.
  AvDecoder(const std::string& path, bool bgr);
  ~AvDecoder();
  AvDecoder(const AvDecoder&) = delete;
  AvDecoder& operator=(const AvDecoder&) = delete;

  enum class Got {
    kFrame,       ///< `frame` and `time_s` are the next frame's
    kUnreadable,  ///< a frame that could not be decoded; `time_s` its time, NaN when not known
    kEnd,         ///< the end of the stream (or a read error: read_error())
  };
  /// The next decoded frame: CV_8UC1 (grey) or CV_8UC3 (BGR), valid until the
  /// next call (it may point into the decoder's buffer), and its time, s;
  /// or the next frame that could not be decoded (counted in decode_errors()).
  Got Read(cv::Mat& frame, double& time_s);
  /// After Read() returned false early: the rest of the stream's packets,
  /// counted without decoding them (frames not read). Reads to the end.
  int64_t CountRemainingPackets();

  double rate_hz() const { return rate_hz_; }       ///< 0: the file gives none
  int64_t announced() const { return announced_; }  ///< frames; 0: not known
  int width() const { return width_; }
  int height() const { return height_; }
  /// Packets the decoder refused and frames it could not decode.
  int64_t decode_errors() const { return decode_errors_; }
  /// Why the read ended before the stream's end (av_read_frame's error); empty otherwise.
  const std::string& read_error() const { return read_error_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double rate_hz_{};
  int64_t announced_{};
  int width_{}, height_{};
  int64_t decode_errors_{};
  std::string read_error_;
};

}  // namespace rocklab::video
