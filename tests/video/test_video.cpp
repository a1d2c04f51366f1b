#include "tests/video/test_video.h"

#include <cstring>
#include <stdexcept>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/opt.h>
}

namespace rocklab::test {

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
  m.Check(avformat_alloc_output_context2(&m.fmt, nullptr, "matroska", path.c_str()), "output context");
  const AVCodec* codec = avcodec_find_encoder(lossless ? AV_CODEC_ID_FFV1 : AV_CODEC_ID_MJPEG);
  if (codec == nullptr) throw std::runtime_error("test video writer: no encoder");
  m.st = avformat_new_stream(m.fmt, nullptr);
  m.ctx = avcodec_alloc_context3(codec);
  m.ctx->width = width;
  m.ctx->height = height;
  m.ctx->time_base = AVRational{1, 1000};
  m.ctx->framerate = AVRational{fps, 1};
  m.ctx->pix_fmt = lossless ? AV_PIX_FMT_GRAY8 : AV_PIX_FMT_YUVJ420P;
  if (!lossless) {
    m.ctx->flags |= AV_CODEC_FLAG_QSCALE;
    m.ctx->global_quality = FF_QP2LAMBDA * mjpeg_q;
  }
  if (m.fmt->oformat->flags & AVFMT_GLOBALHEADER) m.ctx->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  m.Check(avcodec_open2(m.ctx, codec, nullptr), "avcodec_open2");
  m.Check(avcodec_parameters_from_context(m.st->codecpar, m.ctx), "parameters");
  m.st->time_base = AVRational{1, 1000};
  m.st->avg_frame_rate = AVRational{fps, 1};
  m.Check(avio_open(&m.fmt->pb, path.c_str(), AVIO_FLAG_WRITE), "avio_open");
  m.Check(avformat_write_header(m.fmt, nullptr), "write header");
  m.frame = av_frame_alloc();
  m.frame->format = m.ctx->pix_fmt;
  m.frame->width = width;
  m.frame->height = height;
  m.Check(av_frame_get_buffer(m.frame, 0), "frame buffer");
  m.pkt = av_packet_alloc();
}

void TestVideoWriter::Write(const cv::Mat& gray, int64_t pts_ms) {
  Impl& m = *impl_;
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
