// rocklab camera-calibrate VIDEO --board 9x6 --square 0.025 --out cam.toml:
// lens intrinsics and distortion from a video of a chessboard (docs/video.md).
// The options are here; the run is the video plugin's
// (tools/video_plugin_main.cpp).
#include <memory>
#include <string>

#include "tools/cli.h"
#include "tools/video_plugin.h"

namespace rocklab::tools {

void RegisterCameraCalibrate(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<video::CalibrateRequest>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("camera-calibrate", "lens intrinsics and distortion from a chessboard video");
  cmd->add_option("video", opts->video, "video file or image pattern (frames/%06d.png) of a chessboard")->required();
  cmd->add_option("--board", opts->board, "inner corners COLSxROWS")->capture_default_str();
  cmd->add_option("--square", opts->chessboard.square_m, "side of a square, m")->capture_default_str();
  cmd->add_option("--out", opts->out, "intrinsics file (TOML) for [camera.video] intrinsics")->required();
  cmd->add_option("--every", opts->chessboard.every, "look at every Nth frame (0: about 200 frames in all)");
  cmd->add_option("--max-views", opts->chessboard.max_views, "views used at most")->capture_default_str();
  cmd->callback([opts, &run] { run = [opts] { return VideoPlugin().camera_calibrate(*opts); }; });
}

}  // namespace rocklab::tools
