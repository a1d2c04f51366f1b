// lib/rocklab/plugins/rocklab-video.so (package rocklab-video): video/ and OpenCV
// behind video/plugin.h's calls, opened by the rocklab command only for a
// `video:` / `v4l2:` input, `track` or `camera-calibrate`
// (tools/video_plugin.h). The two commands' runs live here; their options
// and help stay in cmd_track.cpp and cmd_camera_calibrate.cpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/logger_clock.h"
#include "common/provenance.h"
#include "daq/rig_config.h"
#include "daq/source.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "video/camera_calibration.h"
#include "video/daq_sync.h"
#include "video/overlay.h"
#include "video/plugin.h"
#include "video/video_config.h"
#include "video/video_source.h"

namespace rocklab::video {
namespace {

using pipeline::OptionError;

constexpr int kShownProblems = 20;

void WriteTrackHeader(std::FILE* out, const std::vector<std::string>& names) {
  std::fprintf(out, "time");
  for (const std::string& n : names) std::fprintf(out, ",%s", n.c_str());
  std::fprintf(out, "\n");
}

void WriteTrackRow(std::FILE* out, double time_s, const std::vector<double>& values) {
  std::fprintf(out, "%.9f", time_s);
  for (double v : values) std::fprintf(out, ",%.10g", v);  // NaN prints "nan", read back as NaN
  std::fprintf(out, "\n");
}

// Closes `out` (written to `part`) and renames it over `path`: whole or not at all.
void FinishTrackCsv(std::FILE* out, const std::string& part, const std::string& path) {
  const bool ok = std::ferror(out) == 0;
  if (std::fclose(out) != 0 || !ok) {
    std::remove(part.c_str());
    throw std::runtime_error("cannot write '" + part + "'");
  }
  std::filesystem::rename(part, path);
}

// The table's displacement seen in the video (sync = "table"), m, per row
// of `video_rows` (NaN where fewer than 2 LEDs are seen): the pivot corner
// of the LEDs' rigid fit (2-D Procrustes: the block frame at rest turned
// by theta and moved by T onto the LEDs seen, theta positive leaning to
// +x as the rig's), which stays on the table: its x minus its x at rest.
std::vector<double> TableSeenInVideo(const daq::RigConfig& rig, const Record& video_rows) {
  const VideoConfig c = LoadVideoConfig(rig);
  struct Column {
    std::size_t x, z;
    double bx, bz;
    const daq::ChannelConfig* cx;
    const daq::ChannelConfig* cz;
  };
  std::vector<Column> cols;
  for (const VideoLed& led : c.leds) {
    const auto ix = std::find(video_rows.names.begin(), video_rows.names.end(), led.x_channel->name);
    const auto iz = std::find(video_rows.names.begin(), video_rows.names.end(), led.z_channel->name);
    if (ix == video_rows.names.end() || iz == video_rows.names.end()) continue;
    cols.push_back({static_cast<std::size_t>(ix - video_rows.names.begin()),
                    static_cast<std::size_t>(iz - video_rows.names.begin()), led.x_m, led.z_m, led.x_channel,
                    led.z_channel});
  }
  const double b = rig.block.pivot_half_width_m();
  std::vector<double> out(video_rows.t_s.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> px, pz, qx, qz;
  for (std::size_t r = 0; r < video_rows.rows.size(); ++r) {
    px.clear(), pz.clear(), qx.clear(), qz.clear();
    for (const Column& col : cols) {
      const double x = col.cx->gain * video_rows.rows[r][col.x] + col.cx->offset;
      const double z = col.cz->gain * video_rows.rows[r][col.z] + col.cz->offset;
      if (!std::isfinite(x) || !std::isfinite(z)) continue;
      px.push_back(col.bx), pz.push_back(col.bz), qx.push_back(x), qz.push_back(z);
    }
    if (px.size() < 2) continue;
    const double n = static_cast<double>(px.size());
    double mpx = 0, mpz = 0, mqx = 0, mqz = 0;
    for (std::size_t i = 0; i < px.size(); ++i) mpx += px[i] / n, mpz += pz[i] / n, mqx += qx[i] / n, mqz += qz[i] / n;
    double cross = 0, dot = 0;
    for (std::size_t i = 0; i < px.size(); ++i) {
      const double ax = px[i] - mpx, az = pz[i] - mpz, cx = qx[i] - mqx, cz = qz[i] - mqz;
      cross += cx * az - cz * ax;
      dot += cx * ax + cz * az;
    }
    // q = R p + T with R = [[cos, sin], [-sin, cos]] (theta > 0 leans to +x).
    const double theta = std::atan2(cross, dot), cs = std::cos(theta), sn = std::sin(theta);
    const double tx = mqx - (cs * mpx + sn * mpz);
    const double corner = theta >= 0 ? b : -b;
    out[r] = cs * corner + tx - corner;
  }
  return out;
}

// rocklab track ... --daq DAQ: the DAQ's record read whole, the clocks
// fitted by the sync LED's edges (video/daq_sync.h), and the record inside
// the video's span written with the video's channels on the DAQ's clock
// (its samples, or a grid at the camera's rate). Returns the summary line.
std::string MergeWithDaq(const TrackRequest& o, const daq::RigConfig& rig, const VideoStats& v,
                         const Record& video_rows, const daq::SourceOptions& video_options, TrackResult& result) {
  if (!v.sync_led && !v.sync_table) {
    throw OptionError("--daq: " + rig.path + " names no sync source ([camera.video] sync = \"led\", sync_led_px, "
                      "sync_channel, or sync = \"table\", sync_channel: docs/video.md)");
  }
  // The merged record is at the rig's rate: the DAQ's samples when that is
  // the DAQ's, else a grid at the camera's rate (then the DAQ record's own
  // rate is its time column's).
  const bool at_camera_rate = std::abs(rig.sample_rate_hz - v.rate_hz) <= 1e-3 * v.rate_hz;
  daq::SourceOptions so;
  so.sample_rate_hz = at_camera_rate ? 0.0 : rig.sample_rate_hz;
  so.rig = &rig;
  so.on_problem = video_options.on_problem;
  for (const auto& c : rig.channels) so.fallback_channel_names.push_back(c.name);
  std::unique_ptr<daq::Source> daq_source;
  try {
    daq_source = daq::OpenSource(o.daq, so);
  } catch (const std::exception& e) {
    throw OptionError(std::string("--daq: ") + e.what());
  }
  if (daq_source->live()) {
    throw OptionError("--daq: " + o.daq + " is a live input; the merge needs the whole record (record it first)");
  }
  Record daq_rows;
  daq_rows.names = daq_source->channel_names();
  daq::Frame frame;
  for (;;) {
    const daq::ReadStatus status = daq_source->Next(frame);
    if (status == daq::ReadStatus::kError) throw std::runtime_error(daq_source->error());
    if (status != daq::ReadStatus::kFrame) break;
    daq_rows.t_s.push_back(frame.time_s);
    daq_rows.rows.push_back(frame.values);
  }
  const auto sync_col = std::find(daq_rows.names.begin(), daq_rows.names.end(), v.sync_channel);
  if (sync_col == daq_rows.names.end()) {
    throw OptionError("--daq: " + o.daq + " has no column '" + v.sync_channel + "' (" + rig.path +
                      ": camera.video.sync_channel)");
  }
  const std::size_t sc = static_cast<std::size_t>(sync_col - daq_rows.names.begin());
  const double frame_period = 1 / v.rate_hz, daq_period = 1 / daq_source->sample_rate_hz();
  ClockFit fit;
  if (v.sync_table) {
    std::vector<double> table;
    for (const auto& r : daq_rows.rows) table.push_back(r[sc]);
    const MotionFit m = FitClockByMotion(video_rows.t_s, TableSeenInVideo(rig, video_rows), daq_rows.t_s, table,
                                         daq_period, "the sync of " + o.video + " with " + o.daq +
                                                         " by the table's motion");
    fit = m.clock;
    result.by_table = true;
    result.correlation = m.correlation;
    result.motion_residual_m = m.residual_rms;
    result.motion_samples = m.samples;
  } else {
    std::vector<double> t, level;
    for (std::size_t i = 0; i < video_rows.t_s.size(); ++i) {
      t.push_back(video_rows.t_s[i] + v.sync_row_delay_s);
      level.push_back(video_rows.rows[i].back());
    }
    double contrast = 0;
    const std::vector<SyncEdge> video_edges = FindSyncEdges(t, level, v.exposure_s, 1.5 * frame_period, &contrast);
    if (contrast < 10) {
      throw std::runtime_error(o.video + ": the sync LED's light changes by " + std::to_string(contrast) +
                               " levels around sync_led_px of " + rig.path + " (fewer than 10: is it there, and lit?)");
    }
    std::vector<double> drive;
    for (const auto& r : daq_rows.rows) drive.push_back(r[sc]);
    double daq_contrast = 0;
    const std::vector<SyncEdge> daq_edges =
        FindSyncEdges(daq_rows.t_s, drive, 0.0, 1.5 * daq_period, &daq_contrast);
    fit = FitClock(video_edges, daq_edges, frame_period, v.exposure_s, daq_period,
                   "the sync of " + o.video + " with " + o.daq);
  }
  std::vector<Resample> kinds;
  auto ends = [](const std::string& n, const std::string& tail) {
    return n.size() >= tail.size() && n.compare(n.size() - tail.size(), tail.size(), tail) == 0;
  };
  for (const std::string& n : video_rows.names) {
    kinds.push_back(ends(n, "_flags")                                                        ? Resample::kFlags
                    : ends(n, "_area_px") || ends(n, "_peak") || ends(n, "_sync_level") ? Resample::kNearest
                                                                                         : Resample::kLinear);
  }
  MergeCounts counts;
  const Record merged =
      MergeOnDaqClock(daq_rows, video_rows, kinds, fit, frame_period, at_camera_rate ? v.rate_hz : 0.0, &counts);
  const std::string part = o.out_csv + ".part";
  std::FILE* out = std::fopen(part.c_str(), "w");
  if (out == nullptr) throw OptionError("--out: cannot write '" + part + "'");
  WriteTrackHeader(out, merged.names);
  for (std::size_t i = 0; i < merged.t_s.size(); ++i) WriteTrackRow(out, merged.t_s[i], merged.rows[i]);
  FinishTrackCsv(out, part, o.out_csv);
  result.synced = true;
  result.rows = counts.rows;
  result.offset_s = fit.offset_s;
  result.offset_se_s = fit.offset_se_s;
  result.drift_ppm = fit.drift_ppm;
  result.drift_se_ppm = fit.drift_se_ppm;
  result.residual_rms_s = fit.residual_rms_s;
  result.residual_max_s = fit.residual_max_s;
  result.expected_rms_s = fit.expected_rms_s;
  result.edges_video = fit.video_edges;
  result.edges_daq = fit.daq_edges;
  result.edges_paired = fit.matched;
  result.rows_before = counts.before;
  result.rows_after = counts.after;
  result.rows_in_gaps = counts.in_gaps;
  // The DAQ's channels on the camera's grid are least-squares chord values
  // (video/daq_sync.h), which the forced fit reads with --table chord.
  static constexpr const char* kAtCameraRate =
      "at the camera's rate (the rig's sample_rate_hz; the DAQ's channels as least-squares chord values: "
      "fit a forced test with --table chord)";
  char line[1024];
  if (result.by_table) {
    std::snprintf(line, sizeof line,
                  "%lld rows merged to %s on the DAQ's clock, %s (%lld DAQ samples before the video's first frame "
                  "and %lld after its last left out, %lld rows between frames a drop apart); sync by the table's "
                  "motion: t_daq = offset + (1 + drift) t_video, offset %.6f s +- %.2g s, drift %.1f +- %.2g ppm; "
                  "%d frames, correlation %.4f, residual RMS %.3g mm",
                  static_cast<long long>(counts.rows), o.out_csv.c_str(),
                  at_camera_rate ? kAtCameraRate : "at the DAQ's samples",
                  static_cast<long long>(counts.before), static_cast<long long>(counts.after),
                  static_cast<long long>(counts.in_gaps), fit.offset_s, fit.offset_se_s, fit.drift_ppm,
                  fit.drift_se_ppm, result.motion_samples, result.correlation, 1e3 * result.motion_residual_m);
    return line;
  }
  std::snprintf(line, sizeof line,
                "%lld rows merged to %s on the DAQ's clock, %s (%lld DAQ samples before the video's first frame "
                "and %lld after its last left out, %lld rows between frames a drop apart); sync: t_daq = offset + (1 + drift) "
                "t_video, offset %.6f s +- %.2g s, drift %.1f +- %.2g ppm; %d of %d video edges paired (%d in the DAQ "
                "record), residual RMS %.3f ms, max %.3f ms (the frame and DAQ periods allow %.3f ms RMS)",
                static_cast<long long>(counts.rows), o.out_csv.c_str(),
                at_camera_rate ? kAtCameraRate : "at the DAQ's samples",
                static_cast<long long>(counts.before),
                static_cast<long long>(counts.after), static_cast<long long>(counts.in_gaps), fit.offset_s,
                fit.offset_se_s, fit.drift_ppm, fit.drift_se_ppm, fit.matched, fit.video_edges, fit.daq_edges,
                1e3 * fit.residual_rms_s, 1e3 * fit.residual_max_s, 1e3 * fit.expected_rms_s);
  return line;
}

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
  video::Record video_rows;  // with --daq: the whole read, merged at the end
  video_rows.names = source->channel_names();
  // Written beside, renamed when whole.
  const std::string part = o.out_csv + ".part";
  std::FILE* out = o.daq.empty() ? std::fopen(part.c_str(), "w") : nullptr;
  if (o.daq.empty() && out == nullptr) throw OptionError("--out: cannot write '" + part + "'");
  if (out != nullptr) WriteTrackHeader(out, source->channel_names());
  daq::Frame frame;
  int64_t rows = 0;
  while ((o.max_frames == 0 || rows < o.max_frames) && !(o.stop != nullptr && o.stop->load())) {
    const daq::ReadStatus status = source->Next(frame);
    if (status == daq::ReadStatus::kIdle) continue;  // a device between frames
    if (status == daq::ReadStatus::kError) {
      // Nothing written: the video could not be read as asked (e.g. no LED
      // for longer than max_dark_s).
      if (out != nullptr) std::fclose(out);
      std::remove(part.c_str());
      throw std::runtime_error(source->error());
    }
    if (status != daq::ReadStatus::kFrame) break;
    if (out != nullptr) {
      WriteTrackRow(out, frame.time_s, frame.values);
    } else {
      video_rows.t_s.push_back(frame.time_s);
      video_rows.rows.push_back(frame.values);
    }
    ++rows;
  }
  std::string sync_line;
  TrackResult result;
  result.rows = rows;
  if (!o.daq.empty()) {
    sync_line = MergeWithDaq(o, rig, *VideoStatsOf(*source), video_rows, options, result);
  } else {
    FinishTrackCsv(out, part, o.out_csv);
  }
  if (overlay) {
    overlay->Commit();
    std::fprintf(stderr, "%lld frames drawn to %s\n", static_cast<long long>(overlay->frames()), o.overlay.c_str());
  }

  const VideoStats& v = *VideoStatsOf(*source);
  if (problems > kShownProblems) std::fprintf(stderr, "rocklab: %ld more problems not shown\n", problems - kShownProblems);
  std::fprintf(stderr, "%lld frames tracked%s %s\n", static_cast<long long>(rows),
               o.daq.empty() ? (" to " + o.out_csv).c_str() : "", VideoSummary(v).c_str());
  if (!sync_line.empty()) std::fprintf(stderr, "%s\n", sync_line.c_str());
  if (o.result != nullptr) {
    result.frames = v.frames.frames;
    result.rate_hz = v.rate_hz;
    result.dropped = v.frames.dropped;
    result.drop_places = v.frames.drop_events;
    result.missing_at_end = v.frames.missing_at_end;
    result.fits = v.track.fits;
    result.led_missing = v.track.missing_samples;
    result.occlusions = v.track.occlusions;
    result.merged = v.track.merged;
    result.ambiguous = v.track.ambiguous;
    result.inconsistent = v.track.inconsistent;
    result.outliers = v.track.outliers;
    result.saturated = v.track.saturated;
    result.reflections = v.track.reflections;
    result.summary = VideoSummary(v);
    *o.result = result;
  }
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
  // What made the file, as comment lines every TOML reader skips (a sweep's
  // results file keeps its own so): the video hashed (an image pattern or
  // device is listed as "could not be read").
  const std::string provenance = common::ProvenanceCommentLines(
      common::ProvenanceFields(common::MakeProvenance({spec})), "rocklab provenance (what made this file)");
  WriteIntrinsics(o.out, k,
                  "rocklab camera-calibrate " + o.video + " --board " + o.board + " --square " +
                      std::to_string(o.chessboard.square_m) + ": lens intrinsics (px) and distortion",
                  provenance);
  // The text on stdout, or on stderr when the command prints JSON there.
  std::FILE* text = o.result != nullptr ? stderr : stdout;
  std::fprintf(text, "%d frames read, %d looked at, board found in %d; %d views used\n", r.frames_read,
               r.frames_searched, r.boards_found, k.views);
  std::fprintf(text, "fx %.3f px, fy %.3f px, cx %.3f px, cy %.3f px; k1 %.5f, k2 %.5f, p1 %.6f, p2 %.6f (k3 held at 0)\n",
               k.fx_px, k.fy_px, k.cx_px, k.cy_px, k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3]);
  std::fprintf(text, "reprojection error: RMS %.4f px over all views, worst view %.4f px; written to %s\n",
               k.rms_reprojection_px, r.worst_view_rms_px, o.out.c_str());
  if (o.result != nullptr) *o.result = r;
  return 0;
}

const PluginCalls kCalls{kPluginVersion, &OpenVideoSource, &RunTrack, &RunCameraCalibrate};

}  // namespace
}  // namespace rocklab::video

extern "C" __attribute__((visibility("default"))) const rocklab::video::PluginCalls* rocklab_video_plugin() {
  rocklab::common::LoadLogLevels();  // this plugin's spdlog registry
  return &rocklab::video::kCalls;
}
