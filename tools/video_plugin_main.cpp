// lib/rocklab/plugins/rocklab-video.so (package rocklab-video): video/ and OpenCV
// behind video/plugin.h's calls, opened by the rocklab command only for a
// `video:` / `v4l2:` input, `track` or `camera-calibrate`
// (tools/video_plugin.h). The two commands' runs live here; their options
// and help stay in cmd_track.cpp and cmd_camera_calibrate.cpp.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "daq/rig_config.h"
#include "daq/source.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "video/camera_calibration.h"
#include "video/overlay.h"
#include "video/plugin.h"
#include "video/video_source.h"

namespace rocklab::video {
namespace {

using pipeline::OptionError;

constexpr int kShownProblems = 20;

// rocklab track VIDEO --rig RIG.toml --out RAW.csv: a camera's video tracked
// into the rig's LED channels (docs/video.md), written as a raw CSV that
// `daq`, `reconstruct` and `run` read like any other.
int RunTrack(const TrackRequest& o) {
  const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
  long problems = 0;
  daq::SourceOptions options;
  options.sample_rate_hz = rig.sample_rate_hz;
  options.rig = &rig;
  options.stop = o.stop;
  options.on_problem = [&problems](const daq::Problem& p) {
    if (++problems <= kShownProblems) std::fprintf(stderr, "rocklab: %s\n", daq::ToString(p).c_str());
  };
  const bool device = o.video.rfind("v4l2:", 0) == 0;
  const std::string spec = o.video.substr(device ? 5 : (o.video.rfind("video:", 0) == 0 ? 6 : 0));
  std::unique_ptr<daq::Source> source;
  try {
    source = OpenVideoSource(spec, device, options,
                             o.fps_hz > 0 ? std::optional<double>(o.fps_hz) : std::nullopt);
  } catch (const std::exception& e) {
    throw OptionError(std::string("VIDEO: ") + e.what());
  }

  // The overlay: opened before the read (a bad name fails first), renamed
  // over its target only when the read ended well.
  std::unique_ptr<OverlayWriter> overlay;
  if (!o.overlay.empty()) {
    const VideoStats& v0 = *VideoStatsOf(*source);
    try {
      overlay = std::make_unique<OverlayWriter>(o.overlay, v0.rate_hz, v0.width_px, v0.height_px);
    } catch (const std::runtime_error& e) {
      throw OptionError(std::string("--overlay: ") + e.what());
    }
    ObserveFrames(*source, [&overlay](const FrameView& f) { overlay->Write(f); });
  }
  // Written beside, renamed when whole.
  const std::string part = o.out_csv + ".part";
  std::FILE* out = std::fopen(part.c_str(), "w");
  if (out == nullptr) throw OptionError("--out: cannot write '" + part + "'");
  std::fprintf(out, "time");
  for (const std::string& n : source->channel_names()) std::fprintf(out, ",%s", n.c_str());
  std::fprintf(out, "\n");
  daq::Frame frame;
  int64_t rows = 0;
  while ((o.max_frames == 0 || rows < o.max_frames) && !(o.stop != nullptr && o.stop->load())) {
    const daq::ReadStatus status = source->Next(frame);
    if (status == daq::ReadStatus::kIdle) continue;  // a device between frames
    if (status == daq::ReadStatus::kError) {
      // Nothing written: the video could not be read as asked (e.g. no LED
      // for longer than max_dark_s).
      std::fclose(out);
      std::remove(part.c_str());
      throw std::runtime_error(source->error());
    }
    if (status != daq::ReadStatus::kFrame) break;
    std::fprintf(out, "%.9f", frame.time_s);
    for (double v : frame.values) std::fprintf(out, ",%.10g", v);  // NaN prints "nan", read back as NaN
    std::fprintf(out, "\n");
    ++rows;
  }
  const bool ok = std::ferror(out) == 0;
  if (std::fclose(out) != 0 || !ok) {
    std::remove(part.c_str());
    throw std::runtime_error("cannot write '" + part + "'");
  }
  std::filesystem::rename(part, o.out_csv);
  if (overlay) {
    overlay->Commit();
    std::fprintf(stderr, "%lld frames drawn to %s\n", static_cast<long long>(overlay->frames()), o.overlay.c_str());
  }

  const VideoStats& v = *VideoStatsOf(*source);
  if (problems > kShownProblems) std::fprintf(stderr, "rocklab: %ld more problems not shown\n", problems - kShownProblems);
  std::fprintf(stderr, "%lld frames tracked to %s %s\n", static_cast<long long>(rows), o.out_csv.c_str(),
               VideoSummary(v).c_str());
  return 0;
}

// rocklab camera-calibrate VIDEO --board 9x6 --square 0.025 --out cam.toml:
// lens intrinsics and distortion from a video of a chessboard (docs/video.md).
int RunCameraCalibrate(const CalibrateRequest& request) {
  CalibrateRequest o = request;
  int cols = 0, rows = 0;
  char tail = 0;
  if (std::sscanf(o.board.c_str(), "%dx%d%c", &cols, &rows, &tail) != 2) {
    throw OptionError("--board: expected COLSxROWS inner corners, e.g. 9x6 (is '" + o.board + "')");
  }
  o.chessboard.cols = cols;
  o.chessboard.rows = rows;
  try {
    o.chessboard.Validate();
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());
  }
  const std::string spec = o.video.rfind("video:", 0) == 0 ? o.video.substr(6) : o.video;
  CalibrationResult r;
  try {
    r = CalibrateFromVideo(spec, o.chessboard);
  } catch (const std::runtime_error& e) {
    throw OptionError(std::string("VIDEO: ") + e.what());
  }
  const Intrinsics& k = r.intrinsics;
  WriteIntrinsics(o.out, k,
                  "rocklab camera-calibrate " + o.video + " --board " + o.board + " --square " +
                      std::to_string(o.chessboard.square_m) + ": lens intrinsics (px) and distortion");
  std::printf("%d frames read, %d looked at, board found in %d; %d views used\n", r.frames_read, r.frames_searched,
              r.boards_found, k.views);
  std::printf("fx %.3f px, fy %.3f px, cx %.3f px, cy %.3f px; k1 %.5f, k2 %.5f, p1 %.6f, p2 %.6f (k3 held at 0)\n",
              k.fx_px, k.fy_px, k.cx_px, k.cy_px, k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3]);
  std::printf("reprojection error: RMS %.4f px over all views, worst view %.4f px; written to %s\n",
              k.rms_reprojection_px, r.worst_view_rms_px, o.out.c_str());
  return 0;
}

const PluginCalls kCalls{kPluginVersion, &OpenVideoSource, &RunTrack, &RunCameraCalibrate};

}  // namespace
}  // namespace rocklab::video

extern "C" __attribute__((visibility("default"))) const rocklab::video::PluginCalls* rocklab_video_plugin() {
  return &rocklab::video::kCalls;
}
