#include "tests/video/test_video.h"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
}

#include "daq/rig_config.h"
#include "daq/source.h"
#include "tests/scratch.h"
#include "video/video_source.h"

namespace rocklab::test {

std::string VideoOpenError(const std::string& name, const std::string& rig_text, const std::string& input) {
  const std::string dir = ScratchDir(name);
  std::ofstream(dir + "/rig.toml") << rig_text;
  video::RegisterSources();
  try {
    const daq::RigConfig rig = daq::LoadRigConfig(dir + "/rig.toml");
    daq::SourceOptions options;
    options.rig = &rig;
    (void)daq::OpenSource(input.empty() ? "video:" + dir + "/none.mkv" : input, options);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string VideoRigText(const TestCamera& cam, double sample_rate_hz, const std::vector<RigLed>& leds,
                         const std::string& video_keys, const std::vector<std::array<double, 2>>& marks) {
  std::ostringstream r;
  r.precision(10);
  r << "name = \"video-test\"\nsample_rate_hz = " << sample_rate_hz << "\n"
    << "[block]\nwidth_m = 0.25\nheight_m = 1.0\n[theta_dot]\nwindow_s = 0.05\norder = 2\n"
    << "[[camera]]\nname = \"side\"\nled = [";
  for (std::size_t i = 0; i < leds.size(); ++i) {
    r << (i == 0 ? "" : ", ") << "{ name = \"" << leds[i].name << "\", x_m = " << leds[i].x_m
      << ", z_m = " << leds[i].z_m << " }";
  }
  r << "]\n[camera.video]\n" << video_keys << "mark = [\n";
  for (const auto& m : marks) {
    const cv::Point2d uv = cam.Project(m[0], m[1]);
    r << "  { u_px = " << uv.x << ", v_px = " << uv.y << ", x_m = " << m[0] << ", z_m = " << m[1] << " },\n";
  }
  r << "]\n";
  for (const RigLed& led : leds) {
    for (const char* axis : {"x", "z"}) {
      r << "[[channel]]\nname = \"side_" << led.name << "_" << axis << "\"\nsensor = \"side." << led.name << "."
        << axis << "\"\ngain = 1.0\nraw_min = -10.0\nraw_max = 10.0\n";
    }
  }
  return r.str();
}

struct TestVideoWriter::Impl {
  AVFormatContext* fmt{};
  AVCodecContext* ctx{};
  AVStream* st{};
  AVFrame* frame{};
  AVPacket* pkt{};
  bool lossless{};
  bool closed{false};
  int h264_crf{-1};  // >= 0: H.264
  int b_frames{0};
  bool colour{false};  // MJPEG 4:4:4 of BGR frames

  void Check(int rc, const char* what) {
    if (rc < 0) {
      char msg[AV_ERROR_MAX_STRING_SIZE] = {};
      av_strerror(rc, msg, sizeof msg);
      throw std::runtime_error(std::string("test video writer: ") + what + ": " + msg);
    }
  }
  int fps{};
  int mjpeg_q{};
  // An encoder for frames of width x height (reopened when the size changes:
  // MJPEG's frames stand alone, so one stream can change size midway).
  void OpenEncoder(int width, int height) {
    const AVCodec* codec = h264_crf >= 0 ? avcodec_find_encoder_by_name("libx264")
                           : avcodec_find_encoder(lossless ? AV_CODEC_ID_FFV1 : AV_CODEC_ID_MJPEG);
    if (codec == nullptr) throw std::runtime_error("test video writer: no encoder");
    ctx = avcodec_alloc_context3(codec);
    ctx->width = width;
    ctx->height = height;
    ctx->time_base = AVRational{1, 1000};
    ctx->framerate = AVRational{fps, 1};
    ctx->pix_fmt = h264_crf >= 0 ? AV_PIX_FMT_YUV420P
                   : lossless    ? AV_PIX_FMT_GRAY8
                   : colour      ? AV_PIX_FMT_YUVJ444P
                                 : AV_PIX_FMT_YUVJ420P;
    ctx->flags |= AV_CODEC_FLAG_BITEXACT;
    if (h264_crf >= 0) {
      ctx->max_b_frames = b_frames;
      ctx->gop_size = 2 * fps;
      av_opt_set(ctx->priv_data, "preset", "veryfast", 0);
      av_opt_set(ctx->priv_data, "crf", std::to_string(h264_crf).c_str(), 0);
      ctx->thread_count = 1;  // the same bytes every time
    } else if (!lossless) {
      ctx->flags |= AV_CODEC_FLAG_QSCALE;
      ctx->global_quality = FF_QP2LAMBDA * mjpeg_q;
    }
    if (fmt->oformat->flags & AVFMT_GLOBALHEADER) ctx->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    Check(avcodec_open2(ctx, codec, nullptr), "avcodec_open2");
    av_frame_free(&frame);
    frame = av_frame_alloc();
    frame->format = ctx->pix_fmt;
    frame->width = width;
    frame->height = height;
    Check(av_frame_get_buffer(frame, 0), "frame buffer");
  }
  void Open(const std::string& path, int width, int height);
  void Drain() {
    while (true) {
      const int rc = avcodec_receive_packet(ctx, pkt);
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return;
      Check(rc, "avcodec_receive_packet");
      av_packet_rescale_ts(pkt, ctx->time_base, st->time_base);
      pkt->stream_index = st->index;
      Check(av_interleaved_write_frame(fmt, pkt), "av_interleaved_write_frame");
    }
  }
};

void TestVideoWriter::Impl::Open(const std::string& path, int width, int height) {
  const bool avi = path.size() > 4 && path.compare(path.size() - 4, 4, ".avi") == 0;
  Check(avformat_alloc_output_context2(&fmt, nullptr, avi ? "avi" : "matroska", path.c_str()), "output context");
  fmt->flags |= AVFMT_FLAG_BITEXACT;  // no random segment UID or writer string: the same bytes every time
  st = avformat_new_stream(fmt, nullptr);
  OpenEncoder(width, height);
  Check(avcodec_parameters_from_context(st->codecpar, ctx), "parameters");
  // AVI has no timestamps: a frame's place in the stream at 1 / fps is its time.
  st->time_base = avi ? AVRational{1, fps} : AVRational{1, 1000};
  st->avg_frame_rate = AVRational{fps, 1};
  Check(avio_open(&fmt->pb, path.c_str(), AVIO_FLAG_WRITE), "avio_open");
  Check(avformat_write_header(fmt, nullptr), "write header");
  pkt = av_packet_alloc();
}

TestVideoWriter::TestVideoWriter(const std::string& path, bool lossless, int width, int height, int fps, int mjpeg_q)
    : impl_(new Impl) {
  impl_->lossless = lossless;
  impl_->fps = fps;
  impl_->mjpeg_q = mjpeg_q;
  impl_->Open(path, width, height);
}

TestVideoWriter TestVideoWriter::H264(const std::string& path, int width, int height, int fps, int crf,
                                      int b_frames) {
  av_log_set_level(AV_LOG_ERROR);  // libx264's statistics stay out of the test's output
  auto* impl = new Impl;
  impl->fps = fps;
  impl->h264_crf = crf;
  impl->b_frames = b_frames;
  TestVideoWriter w(impl);
  impl->Open(path, width, height);
  return w;
}

TestVideoWriter TestVideoWriter::Colour(const std::string& path, int width, int height, int fps, int mjpeg_q) {
  auto* impl = new Impl;
  impl->fps = fps;
  impl->mjpeg_q = mjpeg_q;
  impl->colour = true;
  TestVideoWriter w(impl);
  impl->Open(path, width, height);
  return w;
}

void TestVideoWriter::Write(const cv::Mat& gray, int64_t pts_ms) {
  Impl& m = *impl_;
  if (m.colour != (gray.type() == CV_8UC3)) throw std::runtime_error("test video writer: BGR frames for Colour() only");
  if (gray.cols != m.ctx->width || gray.rows != m.ctx->height) {
    if (m.lossless || m.h264_crf >= 0) throw std::runtime_error("test video writer: FFV1 and H.264 frames keep one size");
    m.Check(avcodec_send_frame(m.ctx, nullptr), "flush");
    m.Drain();
    avcodec_free_context(&m.ctx);
    m.OpenEncoder(gray.cols, gray.rows);
  }
  m.Check(av_frame_make_writable(m.frame), "make writable");
  if (m.colour) {  // BT.601 full range, each pixel its own chroma (4:4:4)
    for (int y = 0; y < gray.rows; ++y) {
      const auto* bgr = gray.ptr<cv::Vec3b>(y);
      for (int x = 0; x < gray.cols; ++x) {
        const double b = bgr[x][0], g = bgr[x][1], r = bgr[x][2];
        const double luma = 0.299 * r + 0.587 * g + 0.114 * b;
        m.frame->data[0][y * m.frame->linesize[0] + x] = cv::saturate_cast<uint8_t>(luma);
        m.frame->data[1][y * m.frame->linesize[1] + x] = cv::saturate_cast<uint8_t>(128 + 0.564 * (b - luma));
        m.frame->data[2][y * m.frame->linesize[2] + x] = cv::saturate_cast<uint8_t>(128 + 0.713 * (r - luma));
      }
    }
    m.frame->pts = pts_ms;
    m.Check(avcodec_send_frame(m.ctx, m.frame), "send frame");
    m.Drain();
    return;
  }
  for (int y = 0; y < gray.rows; ++y) {
    std::memcpy(m.frame->data[0] + y * m.frame->linesize[0], gray.ptr<uint8_t>(y), static_cast<std::size_t>(gray.cols));
  }
  if (!m.lossless) {  // chroma: grey
    for (int p = 1; p < 3; ++p) {
      for (int y = 0; y < (gray.rows + 1) / 2; ++y) {
        std::memset(m.frame->data[p] + y * m.frame->linesize[p], 128, static_cast<std::size_t>((gray.cols + 1) / 2));
      }
    }
  }
  m.frame->pts = pts_ms;
  m.Check(avcodec_send_frame(m.ctx, m.frame), "send frame");
  m.Drain();
}

void TestVideoWriter::Close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.closed = true;
  m.Check(avcodec_send_frame(m.ctx, nullptr), "flush");
  m.Drain();
  m.Check(av_write_trailer(m.fmt), "trailer");
}

TestVideoWriter::~TestVideoWriter() {
  if (impl_ == nullptr) return;  // moved from
  Impl& m = *impl_;
  if (!m.closed) {
    try {
      Close();
    } catch (const std::exception&) {
      // a destructor does not throw; the test already failed where it wrote
    }
  }
  if (m.fmt != nullptr && m.fmt->pb != nullptr) avio_closep(&m.fmt->pb);
  av_packet_free(&m.pkt);
  av_frame_free(&m.frame);
  avcodec_free_context(&m.ctx);
  avformat_free_context(m.fmt);
  delete impl_;
}

}  // namespace rocklab::test
