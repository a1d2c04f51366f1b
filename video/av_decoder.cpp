#include "video/av_decoder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavcodec/codec_desc.h>
#include <libavformat/avformat.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

namespace rocklab::video {
namespace {

std::string AvErrorText(int rc) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(rc, text, sizeof text);
  return text;
}

double RationalOrZero(AVRational r) { return r.num > 0 && r.den > 0 ? av_q2d(r) : 0.0; }

constexpr double kNoTime = std::numeric_limits<double>::quiet_NaN();

// Luma levels 16..235 (limited range) to grey 0..255, as swscale's BGR
// then OpenCV's grey would make them: round((y - 16) x 255 / 219), clamped.
cv::Mat LimitedToFullRangeTable() {
  cv::Mat lut(1, 256, CV_8U);
  for (int y = 0; y < 256; ++y) {
    lut.at<uint8_t>(0, y) = cv::saturate_cast<uint8_t>(std::lround((y - 16) * 255.0 / 219.0));
  }
  return lut;
}

// Sends one packet of a codec whose frames stand alone and takes its frame:
// 0, or FFmpeg's error (AVERROR(EAGAIN): the packet gave no frame).
int DecodeAlone(AVCodecContext* codec, AVPacket* packet, AVFrame* frame) {
  const int sent = avcodec_send_packet(codec, packet);
  av_packet_unref(packet);
  if (sent < 0) return sent;
  return avcodec_receive_frame(codec, frame);
}

}  // namespace

// A second MJPEG decoder on its own thread: it decodes every other packet
// while the reading thread decodes the one before. FFmpeg 5.1's MJPEG
// decoder has no threads of its own, and each JPEG stands alone.
struct AvMjpegHelper {
  AVCodecContext* codec{};
  AVPacket* packet{};
  AVFrame* frame{};
  std::thread thread;
  std::mutex mutex;
  std::condition_variable changed;
  bool job{false}, quit{false};
  int result{0};

  AvMjpegHelper(const AVCodec* decoder, const AVCodecParameters* parameters, AVRational time_base) {
    codec = avcodec_alloc_context3(decoder);
    packet = av_packet_alloc();
    frame = av_frame_alloc();
    if (codec == nullptr || packet == nullptr || frame == nullptr) throw std::runtime_error("out of memory");
    int rc = avcodec_parameters_to_context(codec, parameters);
    codec->pkt_timebase = time_base;
    codec->thread_count = 1;
    codec->err_recognition |= AV_EF_EXPLODE;  // as the first decoder: a damaged JPEG refused
    if (rc >= 0) rc = avcodec_open2(codec, decoder, nullptr);
    if (rc < 0) throw std::runtime_error("cannot open a second decoder (FFmpeg: " + AvErrorText(rc) + ")");
    thread = std::thread([this] { Run(); });
  }
  ~AvMjpegHelper() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      quit = true;
    }
    changed.notify_all();
    if (thread.joinable()) thread.join();
    av_frame_free(&frame);
    av_packet_free(&packet);
    avcodec_free_context(&codec);
  }
  AvMjpegHelper(const AvMjpegHelper&) = delete;
  AvMjpegHelper& operator=(const AvMjpegHelper&) = delete;

  void Run() {
    std::unique_lock<std::mutex> lock(mutex);
    while (true) {
      changed.wait(lock, [this] { return job || quit; });
      if (quit) return;
      lock.unlock();
      const int r = DecodeAlone(codec, packet, frame);
      lock.lock();
      result = r;
      job = false;
      changed.notify_all();
    }
  }
  void Start() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      job = true;
    }
    changed.notify_all();
  }
  int Wait() {
    std::unique_lock<std::mutex> lock(mutex);
    changed.wait(lock, [this] { return !job; });
    return result;
  }
};

struct AvDecoder::Impl {
  AVFormatContext* format{};
  AVCodecContext* codec{};
  AVPacket* packet{};
  AVFrame* frame{};
  SwsContext* sws{};
  int stream{-1};
  AVRational time_base{0, 1};
  int64_t start{0};  // the stream's start time, time_base units
  bool bgr{false};
  bool flushing{false};  // the file's end reached: the decoder gives what it holds
  bool ended{false};
  cv::Mat converted;     // reused: BGR, or luma stretched to full range
  cv::Mat limited_lut{LimitedToFullRangeTable()};
  std::unique_ptr<AvMjpegHelper> helper;  // MJPEG: the second decoder
  // MJPEG: what the last pair of packets gave, in the file's order: the
  // first decoder's outcome (first_*) then the helper's (second_*), each
  // a frame to give (0), a frame refused (< 0) or nothing left (1).
  int first_state{1}, second_state{1};
  double first_time_s{}, second_time_s{};  // their packets' times
  bool intra_only{false};  // a packet is a frame standing alone: a refused packet's time is its frame's
  // AVI: (chunk's place in the file, frame number) from the file's index,
  // by place; empty for other containers or an AVI without its index.
  std::vector<std::pair<int64_t, int64_t>> avi_index;

  ~Impl() {
    helper.reset();  // its thread stops first
    sws_freeContext(sws);
    av_frame_free(&frame);
    av_packet_free(&packet);
    avcodec_free_context(&codec);
    avformat_close_input(&format);
  }

  // The next packet of the video stream into `p`; false at the end (or a
  // read error, kept in `error`).
  bool NextPacket(AVPacket* p, std::string& error) {
    while (true) {
      const int rc = av_read_frame(format, p);
      if (rc < 0) {
        if (rc != AVERROR_EOF) error = AvErrorText(rc);
        return false;
      }
      // An empty chunk (AVI's "no frame stored here") is no frame: its
      // place shows as a gap in the next frame's time. (Sent to the decoder
      // it would read as the end of the stream.)
      if (p->stream_index == stream && p->size > 0) {
        Restamp(p);
        return true;
      }
      av_packet_unref(p);
    }
  }

  // AVI: the frame number of the index entry at the packet's place, for its
  // time (the demuxer's is the count of chunks read so far).
  void Restamp(AVPacket* p) const {
    if (avi_index.empty() || p->pos < 0) return;
    const int64_t chunk = p->pos - kAviChunkHeaderBytes;
    const auto it = std::lower_bound(avi_index.begin(), avi_index.end(), std::make_pair(chunk, int64_t{0}),
                                     [](const auto& a, const auto& b) { return a.first < b.first; });
    if (it == avi_index.end() || it->first != chunk) return;  // not in the index: the demuxer's time
    p->dts = p->pts = it->second;
  }
  static constexpr int64_t kAviChunkHeaderBytes = 8;  // "00dc" and the size: the index points at them

  // A packet's time less the stream's start, s; NaN when it has none.
  double PacketTime(const AVPacket& p) const {
    const int64_t ts = p.pts != AV_NOPTS_VALUE ? p.pts : p.dts;
    return ts == AV_NOPTS_VALUE ? kNoTime : static_cast<double>(ts - start) * av_q2d(time_base);
  }

  // OpenCV's picture time: the best-effort timestamp, else the packet's
  // decoding time; none: 0 (FrameReader's "no time"), s.
  double TimeOf(const AVFrame& f) const {
    int64_t pts = f.best_effort_timestamp;
    if (pts == AV_NOPTS_VALUE) pts = f.pkt_dts;
    return pts == AV_NOPTS_VALUE ? 0.0 : static_cast<double>(pts - start) * av_q2d(time_base);
  }

  // A decoded frame with its time; unreadable (counted) for a pixel format
  // swscale cannot take.
  Got Give(const AVFrame& f, cv::Mat& out, double& time_s, int64_t& errors) {
    time_s = TimeOf(f);
    try {
      Convert(f, out);
    } catch (const std::exception&) {
      ++errors;
      return Got::kUnreadable;
    }
    return Got::kFrame;
  }

  // One outcome of the last pair (`state` then spent): its frame, or a
  // frame refused at its packet's time (counted).
  Got Take(int& state, const AVFrame& f, double packet_time_s, cv::Mat& out, double& time_s, int64_t& errors) {
    const int was = state;
    state = 1;
    if (was == 0) return Give(f, out, time_s, errors);
    ++errors;  // a frame that could not be decoded
    time_s = packet_time_s;
    return Got::kUnreadable;
  }

  // MJPEG: two packets at a time, the second decoded by the helper; their
  // outcomes given in the file's order.
  Got ReadPaired(cv::Mat& out, double& time_s, int64_t& errors, std::string& error) {
    while (true) {
      if (first_state != 1) return Take(first_state, *frame, first_time_s, out, time_s, errors);
      if (second_state != 1) return Take(second_state, *helper->frame, second_time_s, out, time_s, errors);
      if (ended || !NextPacket(packet, error)) break;
      const bool second = NextPacket(helper->packet, error);
      first_time_s = PacketTime(*packet);
      second_time_s = second ? PacketTime(*helper->packet) : kNoTime;
      if (second) helper->Start();
      // EAGAIN (a packet that gives no frame, as an empty one) is nothing to give.
      const auto outcome = [](int rc) { return rc == AVERROR(EAGAIN) ? 1 : rc < 0 ? -1 : 0; };
      first_state = outcome(DecodeAlone(codec, packet, frame));
      second_state = second ? outcome(helper->Wait()) : 1;
    }
    ended = true;
    return Got::kEnd;
  }

  // The decoded frame as 8-bit grey (its luma plane) or BGR (swscale).
  void Convert(const AVFrame& f, cv::Mat& out) {
    const auto fmt = static_cast<AVPixelFormat>(f.format);
    const AVPixFmtDescriptor* d = av_pix_fmt_desc_get(fmt);
    const bool luma8 = d != nullptr &&
                       (d->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL | AV_PIX_FMT_FLAG_BITSTREAM |
                                    AV_PIX_FMT_FLAG_HWACCEL | AV_PIX_FMT_FLAG_FLOAT)) == 0 &&
                       d->comp[0].plane == 0 && d->comp[0].depth == 8 && d->comp[0].step == 1 &&
                       d->comp[0].shift == 0 && d->comp[0].offset == 0;
    if (!bgr && luma8) {
      const cv::Mat luma(f.height, f.width, CV_8U, f.data[0], static_cast<std::size_t>(f.linesize[0]));
      // Full range: JPEG's yuvj formats, grey, or a stream that says so;
      // others are limited (16..235), as swscale takes them.
      const bool full = fmt == AV_PIX_FMT_YUVJ420P || fmt == AV_PIX_FMT_YUVJ422P || fmt == AV_PIX_FMT_YUVJ444P ||
                        fmt == AV_PIX_FMT_YUVJ440P || fmt == AV_PIX_FMT_YUVJ411P || fmt == AV_PIX_FMT_GRAY8 ||
                        f.color_range == AVCOL_RANGE_JPEG;
      if (full) {
        out = luma;  // no copy: valid until the next frame
      } else {
        cv::LUT(luma, limited_lut, converted);
        out = converted;
      }
      return;
    }
    sws = sws_getCachedContext(sws, f.width, f.height, fmt, f.width, f.height, AV_PIX_FMT_BGR24, SWS_BICUBIC,
                               nullptr, nullptr, nullptr);
    if (sws == nullptr) throw std::runtime_error("no conversion from pixel format " + std::to_string(f.format));
    converted.create(f.height, f.width, CV_8UC3);
    std::array<uint8_t*, 4> dst{converted.data, nullptr, nullptr, nullptr};
    std::array<int, 4> dst_step{static_cast<int>(converted.step), 0, 0, 0};
    sws_scale(sws, f.data, f.linesize, 0, f.height, dst.data(), dst_step.data());
    out = converted;
  }
};

AvDecoder::AvDecoder(const std::string& path, bool bgr) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.bgr = bgr;
  // Decode errors are counted and said by rocklab, not printed by FFmpeg.
  if (av_log_get_level() > AV_LOG_FATAL) av_log_set_level(AV_LOG_FATAL);
  int rc = avformat_open_input(&m.format, path.c_str(), nullptr, nullptr);
  if (rc < 0) throw std::runtime_error(path + ": cannot be opened as a video (FFmpeg: " + AvErrorText(rc) + ")");
  rc = avformat_find_stream_info(m.format, nullptr);
  if (rc < 0) throw std::runtime_error(path + ": no stream information (FFmpeg: " + AvErrorText(rc) + ")");
  const AVCodec* codec = nullptr;
  m.stream = av_find_best_stream(m.format, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (m.stream < 0 || codec == nullptr) {
    throw std::runtime_error(path + ": no video stream that FFmpeg can decode (" + AvErrorText(m.stream) + ")");
  }
  for (unsigned i = 0; i < m.format->nb_streams; ++i) {
    if (static_cast<int>(i) != m.stream) m.format->streams[i]->discard = AVDISCARD_ALL;
  }
  const AVStream* st = m.format->streams[m.stream];
  m.time_base = st->time_base;
  m.start = st->start_time == AV_NOPTS_VALUE ? 0 : st->start_time;
  m.codec = avcodec_alloc_context3(codec);
  m.packet = av_packet_alloc();
  m.frame = av_frame_alloc();
  if (m.codec == nullptr || m.packet == nullptr || m.frame == nullptr) throw std::runtime_error(path + ": out of memory");
  rc = avcodec_parameters_to_context(m.codec, st->codecpar);
  if (rc >= 0) {
    m.codec->pkt_timebase = st->time_base;
    m.codec->thread_count = 0;  // FFmpeg's choice (the cores), as OpenCV's reader
    // MJPEG: a damaged JPEG refused (counted unreadable), not concealed.
    if (codec->id == AV_CODEC_ID_MJPEG) m.codec->err_recognition |= AV_EF_EXPLODE;
    rc = avcodec_open2(m.codec, codec, nullptr);
  }
  if (rc < 0) throw std::runtime_error(path + ": cannot open its decoder (FFmpeg: " + AvErrorText(rc) + ")");
  if (codec->id == AV_CODEC_ID_MJPEG) {
    try {
      m.helper = std::make_unique<AvMjpegHelper>(codec, st->codecpar, st->time_base);
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ": " + e.what());
    }
  }
  const AVCodecDescriptor* desc = avcodec_descriptor_get(codec->id);
  m.intra_only = desc != nullptr && (desc->props & AV_CODEC_PROP_INTRA_ONLY) != 0;
  if (std::strcmp(m.format->iformat->name, "avi") == 0) {
    // The index as the demuxer loaded it from idx1 (a video chunk's entry:
    // its place, and its frame number as the timestamp, in time_base units).
    const int entries = avformat_index_get_entries_count(st);
    m.avi_index.reserve(static_cast<std::size_t>(std::max(entries, 0)));
    for (int i = 0; i < entries; ++i) {
      const AVIndexEntry* e = avformat_index_get_entry(const_cast<AVStream*>(st), i);
      if (e != nullptr) m.avi_index.emplace_back(e->pos, e->timestamp);
    }
    std::sort(m.avi_index.begin(), m.avi_index.end());
  }
  width_ = st->codecpar->width;
  height_ = st->codecpar->height;
  // The rate and frame count as OpenCV's reader has them (CAP_PROP_FPS,
  // CAP_PROP_FRAME_COUNT), without its fallback of 1 / time base.
  rate_hz_ = RationalOrZero(st->r_frame_rate);
  if (rate_hz_ <= 0) rate_hz_ = RationalOrZero(st->avg_frame_rate);
  announced_ = st->nb_frames > 0 ? st->nb_frames : 0;
  if (announced_ == 0 && rate_hz_ > 0) {
    double duration_s = m.format->duration > 0 ? static_cast<double>(m.format->duration) / AV_TIME_BASE : 0.0;
    if (duration_s <= 0 && st->duration > 0) duration_s = static_cast<double>(st->duration) * av_q2d(st->time_base);
    if (duration_s > 0) announced_ = static_cast<int64_t>(std::floor(duration_s * rate_hz_ + 0.5));
  }
}

AvDecoder::~AvDecoder() = default;

AvDecoder::Got AvDecoder::Read(cv::Mat& out, double& time_s) {
  Impl& m = *impl_;
  if (m.helper) return m.ReadPaired(out, time_s, decode_errors_, read_error_);
  while (!m.ended) {
    const int got = avcodec_receive_frame(m.codec, m.frame);
    if (got == 0) return m.Give(*m.frame, out, time_s, decode_errors_);
    if (got == AVERROR_EOF) {
      m.ended = true;
      break;
    }
    if (got != AVERROR(EAGAIN)) {
      ++decode_errors_;  // a frame that could not be decoded; which packet's, not known here
      time_s = kNoTime;
      return Got::kUnreadable;
    }
    if (m.flushing) {  // nothing more will come
      m.ended = true;
      break;
    }
    if (!m.NextPacket(m.packet, read_error_)) {
      m.flushing = true;
      avcodec_send_packet(m.codec, nullptr);  // the decoder's held frames come next
      continue;
    }
    const double packet_time_s = m.PacketTime(*m.packet);
    const int sent = avcodec_send_packet(m.codec, m.packet);
    av_packet_unref(m.packet);
    if (sent < 0 && sent != AVERROR(EAGAIN)) {
      ++decode_errors_;  // the packet refused: its frame's time where a packet is a frame
      time_s = m.intra_only ? packet_time_s : kNoTime;
      return Got::kUnreadable;
    }
  }
  return Got::kEnd;
}

int64_t AvDecoder::CountRemainingPackets() {
  Impl& m = *impl_;
  // The pair's outcomes not given yet (decoded or refused): frames of the file too.
  int64_t n = (m.first_state != 1 ? 1 : 0) + (m.second_state != 1 ? 1 : 0);
  m.first_state = m.second_state = 1;
  if (m.flushing || m.ended) return n;
  while (av_read_frame(m.format, m.packet) >= 0) {
    if (m.packet->stream_index == m.stream) ++n;
    av_packet_unref(m.packet);
  }
  m.flushing = m.ended = true;
  return n;
}

}  // namespace rocklab::video
