// rocklab track VIDEO --rig RIG.toml --out RAW.csv: a camera's video tracked
// into the rig's LED channels (docs/video.md), written as a raw CSV that
// `daq`, `reconstruct` and `run` read like any other. The options are
// here; the run is the video plugin's (tools/video_plugin_main.cpp).
#include <memory>
#include <string>

#include "common/provenance.h"
#include "tools/cli.h"
#include "tools/video_plugin.h"

namespace rocklab::tools {

void RegisterTrack(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<video::TrackRequest>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("track", "track a camera's LEDs in a video into the rig's LED channels (raw CSV)");
  cmd->add_option("video", opts->video,
                  "video file (mp4, mkv, avi...), image pattern (frames/%06d.png), or v4l2:/dev/videoN; "
                  "a leading video: is accepted")
      ->required();
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML) with a [camera.video] section")->required();
  cmd->add_option("--out", opts->out_csv,
                  "raw CSV: time (s), the camera's LED channels (raw units of the rig's channels), and per LED "
                  "<camera>_<led>_area_px, _peak (8-bit), _flags, then _sigma_x_m, _sigma_z_m (the centroid's "
                  "noise, m) (docs/video.md)")
      ->required();
  cmd->add_option("--fps", opts->fps_hz,
                  "the camera's true frame rate, Hz: stamps frame k at t0 + k / fps (a slow-motion export "
                  "stored at 30 frames/s); over the rig's [camera.video] fps and the container's rate")
      ->check(CLI::Range(0.01, 1e6));
  cmd->add_option("--overlay", opts->overlay,
                  "also write OUT.mkv or OUT.avi (MJPEG): each frame with the identified LEDs and their names, the "
                  "rejected ones and why, the blobs no LED took, and theta drawn (whole or not at all)");
  cmd->add_option("--frames", opts->max_frames, "stop after this many frames (0: all; a device: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([opts, &run] {
    run = [opts] {
      opts->stop = &InstallStopSignals();
      const int rc = VideoPlugin().track(*opts);
      // Beside the raw CSV (its readers stay as they are); a device or an
      // image pattern is listed as not readable (MakeProvenance).
      if (rc == 0) common::WriteProvenanceSidecar(opts->out_csv, {opts->video, opts->rig_path});
      return rc;
    };
  });
}

}  // namespace rocklab::tools
