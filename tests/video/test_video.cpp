#include "tests/video/test_video.h"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
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
    const AVCodec* codec = avcodec_find_encoder(lossless ? AV_CODEC_ID_FFV1 : AV_CODEC_ID_MJPEG);
    if (codec == nullptr) throw std::runtime_error("test video writer: no encoder");
    ctx = avcodec_alloc_context3(codec);
    ctx->width = width;
    ctx->height = height;
    ctx->time_base = AVRational{1, 1000};
    ctx->framerate = AVRational{fps, 1};
    ctx->pix_fmt = lossless ? AV_PIX_FMT_GRAY8 : AV_PIX_FMT_YUVJ420P;
    if (!lossless) {
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

TestVideoWriter::TestVideoWriter(const std::string& path, bool lossless, int width, int height, int fps, int mjpeg_q)
    : impl_(new Impl) {
  Impl& m = *impl_;
  m.lossless = lossless;
  m.fps = fps;
  m.mjpeg_q = mjpeg_q;
  m.Check(avformat_alloc_output_context2(&m.fmt, nullptr, "matroska", path.c_str()), "output context");
  m.st = avformat_new_stream(m.fmt, nullptr);
  m.OpenEncoder(width, height);
  m.Check(avcodec_parameters_from_context(m.st->codecpar, m.ctx), "parameters");
  m.st->time_base = AVRational{1, 1000};
  m.st->avg_frame_rate = AVRational{fps, 1};
  m.Check(avio_open(&m.fmt->pb, path.c_str(), AVIO_FLAG_WRITE), "avio_open");
  m.Check(avformat_write_header(m.fmt, nullptr), "write header");
  m.pkt = av_packet_alloc();
}

void TestVideoWriter::Write(const cv::Mat& gray, int64_t pts_ms) {
  Impl& m = *impl_;
  if (gray.cols != m.ctx->width || gray.rows != m.ctx->height) {
    if (m.lossless) throw std::runtime_error("test video writer: FFV1 frames keep one size");
    m.Check(avcodec_send_frame(m.ctx, nullptr), "flush");
    m.Drain();
    avcodec_free_context(&m.ctx);
    m.OpenEncoder(gray.cols, gray.rows);
  }
  m.Check(av_frame_make_writable(m.frame), "make writable");
  for (int y = 0; y < gray.rows; ++y) {
    std::memcpy(m.frame->data[0] + y * m.frame->linesize[0], gray.ptr<uint8_t>(y), static_cast<std::size_t>(gray.cols));
  }
  if (!m.lossless) {
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
