// rocklab camera-calibrate VIDEO --board 9x6 --square 0.025 --out cam.toml:
// lens intrinsics and distortion from a video of a chessboard (docs/video.md).
#include <cstdio>
#include <memory>
#include <string>

#include "tools/cli.h"
#include "video/camera_calibration.h"

namespace rocklab::tools {
namespace {

struct CalibrateOptions {
  std::string video;
  std::string board{"9x6"};
  std::string out;
  video::ChessboardOptions chessboard;
};

int RunCameraCalibrate(CalibrateOptions o) {
  int cols = 0, rows = 0;
  char tail = 0;
  if (std::sscanf(o.board.c_str(), "%dx%d%c", &cols, &rows, &tail) != 2) {
    throw UsageError("--board: expected COLSxROWS inner corners, e.g. 9x6 (is '" + o.board + "')");
  }
  o.chessboard.cols = cols;
  o.chessboard.rows = rows;
  try {
    o.chessboard.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const std::string spec = o.video.rfind("video:", 0) == 0 ? o.video.substr(6) : o.video;
  video::CalibrationResult r;
  try {
    r = video::CalibrateFromVideo(spec, o.chessboard);
  } catch (const std::runtime_error& e) {
    throw UsageError(std::string("VIDEO: ") + e.what());
  }
  const video::Intrinsics& k = r.intrinsics;
  video::WriteIntrinsics(o.out, k,
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

}  // namespace

void RegisterCameraCalibrate(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<CalibrateOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("camera-calibrate", "lens intrinsics and distortion from a chessboard video");
  cmd->add_option("video", opts->video, "video file or image pattern (frames/%06d.png) of a chessboard")->required();
  cmd->add_option("--board", opts->board, "inner corners COLSxROWS")->capture_default_str();
  cmd->add_option("--square", opts->chessboard.square_m, "side of a square, m")->capture_default_str();
  cmd->add_option("--out", opts->out, "intrinsics file (TOML) for [camera.video] intrinsics")->required();
  cmd->add_option("--every", opts->chessboard.every, "look at every Nth frame (0: about 200 frames in all)");
  cmd->add_option("--max-views", opts->chessboard.max_views, "views used at most")->capture_default_str();
  cmd->callback([opts, &run] { run = [opts] { return RunCameraCalibrate(*opts); }; });
}

}  // namespace rocklab::tools
