// rocklab camera-calibrate VIDEO --board 9x6 --square 0.025 --out cam.toml:
// lens intrinsics and distortion from a video of a chessboard (docs/video.md).
// The options are here; the run is the video plugin's
// (tools/video_plugin_main.cpp).
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

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
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json,
                "print the result as JSON on stdout (the intrinsics, the reprojection errors, the frames and views "
                "used); the text goes to stderr");
  cmd->callback([opts, json, &run] {
    run = [opts, json] {
      video::CalibrationResult result;
      if (*json) opts->result = &result;
      const int rc = VideoPlugin().camera_calibrate(*opts);
      if (rc == 0 && *json) {
        const video::Intrinsics& k = result.intrinsics;
        WriteResult({{"out", opts->out},
                     {"video", opts->video},
                     {"board", opts->board},
                     {"square_m", opts->chessboard.square_m},
                     {"frames_read", result.frames_read},
                     {"frames_searched", result.frames_searched},
                     {"boards_found", result.boards_found},
                     {"views", k.views},
                     {"fx_px", k.fx_px},
                     {"fy_px", k.fy_px},
                     {"cx_px", k.cx_px},
                     {"cy_px", k.cy_px},
                     {"distortion", k.distortion},
                     {"width_px", k.width_px},
                     {"height_px", k.height_px},
                     {"rms_reprojection_px", k.rms_reprojection_px},
                     {"worst_view_rms_px", result.worst_view_rms_px}},
                    true);
      }
      return rc;
    };
  });
}

}  // namespace rocklab::tools
