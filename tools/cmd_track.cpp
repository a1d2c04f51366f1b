// rocklab track VIDEO --rig RIG.toml --out RAW.csv: a camera's video tracked
// into the rig's LED channels (docs/video.md), written as a raw CSV that
// `daq`, `reconstruct` and `run` read like any other. The options are
// here; the run is the video plugin's (tools/video_plugin_main.cpp).
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/provenance.h"
#include "tools/cli.h"
#include "tools/video_plugin.h"

namespace rocklab::tools {
namespace {

// `track --json`: the plugin's counts (video/plugin.h, TrackResult).
nlohmann::json TrackJson(const video::TrackResult& r, const video::TrackRequest& o) {
  nlohmann::json j = {{"out", o.out_csv},
                      {"video", o.video},
                      {"frames", r.frames},
                      {"rows", r.rows},
                      {"rate_hz", r.rate_hz},
                      {"dropped", r.dropped},
                      {"drop_places", r.drop_places},
                      {"missing_at_end", r.missing_at_end},
                      {"fits", r.fits},
                      {"led_samples",
                       {{"missing", r.led_missing},
                        {"occlusions", r.occlusions},
                        {"merged", r.merged},
                        {"ambiguous", r.ambiguous},
                        {"inconsistent", r.inconsistent},
                        {"outliers", r.outliers},
                        {"saturated", r.saturated}}},
                      {"reflections", r.reflections},
                      {"summary", r.summary}};
  if (r.synced) {
    j["sync"] = {{"daq", o.daq},
                 {"offset_s", r.offset_s},
                 {"offset_se_s", r.offset_se_s},
                 {"drift_ppm", r.drift_ppm},
                 {"drift_se_ppm", r.drift_se_ppm},
                 {"residual_rms_s", r.residual_rms_s},
                 {"residual_max_s", r.residual_max_s},
                 {"expected_rms_s", r.expected_rms_s},
                 {"edges_video", r.edges_video},
                 {"edges_daq", r.edges_daq},
                 {"edges_paired", r.edges_paired},
                 {"rows_before", r.rows_before},
                 {"rows_after", r.rows_after},
                 {"rows_in_gaps", r.rows_in_gaps},
                 {"method", r.by_table ? "table" : "led"}};
    if (r.by_table) {
      j["sync"]["correlation"] = r.correlation;
      j["sync"]["motion_residual_m"] = r.motion_residual_m;
      j["sync"]["motion_samples"] = r.motion_samples;
    }
  }
  return j;
}

}  // namespace

void RegisterTrack(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<video::TrackRequest>();  // shared: owned by the callback
  auto json = std::make_shared<bool>(false);
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
  cmd->add_option("--daq", opts->daq,
                  "the DAQ's raw record (CSV, LVM, LCM log) with the column driving the rig's sync LED "
                  "([camera.video] sync = \"led\"), or its table displacement (sync = \"table\": the table's "
                  "motion seen in the video): --out is then that record inside the video's span with the "
                  "video's channels added on the DAQ's clock; the clock offset and drift are fitted and reported");
  cmd->add_flag("--json", *json, "print the result as JSON on stdout: the counts, and with --daq the clocks "
                                  "(offset_s, drift_ppm, their standard errors, the residuals)");
  cmd->add_option("--frames", opts->max_frames, "stop after this many frames (0: all; a device: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([opts, json, &run] {
    run = [opts, json] {
      opts->stop = &InstallStopSignals();
      video::TrackResult result;
      opts->result = &result;
      const int rc = VideoPlugin().track(*opts);
      // Beside the raw CSV (its readers stay as they are); a device or an
      // image pattern is listed as not readable (MakeProvenance).
      if (rc == 0) {
        std::vector<std::string> inputs{opts->video, opts->rig_path};
        if (!opts->daq.empty()) inputs.push_back(opts->daq);
        common::WriteProvenanceSidecar(opts->out_csv, inputs);
        if (*json) WriteResult(TrackJson(result, *opts), true);
      }
      return rc;
    };
  });
}

}  // namespace rocklab::tools
