// rocklab track VIDEO --rig RIG.toml --out RAW.csv: a camera's video tracked
// into the rig's LED channels (docs/video.md), written as a raw CSV that
// `daq`, `reconstruct` and `run` read like any other.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "daq/rig_config.h"
#include "daq/source.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"
#include "video/video_source.h"

namespace rocklab::tools {
namespace {

struct TrackOptions {
  std::string video;
  std::string rig_path;
  std::string out_csv;
  int64_t max_frames{0};
};

constexpr int kShownProblems = 20;

int RunTrack(const TrackOptions& o) {
  const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
  long problems = 0;
  daq::SourceOptions options;
  options.sample_rate_hz = rig.sample_rate_hz;
  options.rig = &rig;
  options.stop = &InstallStopSignals();
  options.on_problem = [&problems](const daq::Problem& p) {
    if (++problems <= kShownProblems) std::fprintf(stderr, "rocklab: %s\n", daq::ToString(p).c_str());
  };
  const bool device = o.video.rfind("v4l2:", 0) == 0;
  const std::string spec = o.video.substr(device ? 5 : (o.video.rfind("video:", 0) == 0 ? 6 : 0));
  std::unique_ptr<daq::Source> source;
  try {
    source = video::OpenVideoSource(spec, device, options);
  } catch (const std::exception& e) {
    throw UsageError(std::string("VIDEO: ") + e.what());
  }

  // Written beside, renamed when whole.
  const std::string part = o.out_csv + ".part";
  std::FILE* out = std::fopen(part.c_str(), "w");
  if (out == nullptr) throw UsageError("--out: cannot write '" + part + "'");
  std::fprintf(out, "time");
  for (const std::string& n : source->channel_names()) std::fprintf(out, ",%s", n.c_str());
  std::fprintf(out, "\n");
  daq::Frame frame;
  int64_t rows = 0;
  while ((o.max_frames == 0 || rows < o.max_frames) && !options.stop->load()) {
    const daq::ReadStatus status = source->Next(frame);
    if (status == daq::ReadStatus::kIdle) continue;  // a device between frames
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

  const video::VideoStats& v = *video::VideoStatsOf(*source);
  if (problems > kShownProblems) std::fprintf(stderr, "rocklab: %ld more problems not shown\n", problems - kShownProblems);
  std::fprintf(stderr,
               "%lld frames tracked to %s (%dx%d px, %.6g frames/s from %s); %lld dropped in %lld places, "
               "%lld repeated, %lld out of order, %lld unreadable; LED samples: %lld missing "
               "(%lld occlusions), %lld merged, %lld ambiguous, %lld inconsistent, %lld saturated; "
               "%lld stray blobs (reflections); rigid fits in %lld frames; marks fit to %.3g mm (%.3g px), "
               "%.3g mm/px\n",
               static_cast<long long>(rows), o.out_csv.c_str(), v.width_px, v.height_px, v.rate_hz,
               v.rate_source.c_str(), static_cast<long long>(v.frames.dropped),
               static_cast<long long>(v.frames.drop_events), static_cast<long long>(v.frames.repeated),
               static_cast<long long>(v.frames.backwards), static_cast<long long>(v.frames.unreadable),
               static_cast<long long>(v.track.missing_samples), static_cast<long long>(v.track.occlusions),
               static_cast<long long>(v.track.merged), static_cast<long long>(v.track.ambiguous),
               static_cast<long long>(v.track.inconsistent), static_cast<long long>(v.track.saturated),
               static_cast<long long>(v.track.reflections), static_cast<long long>(v.track.fits),
               1e3 * v.mark_rms_m, v.mark_rms_px, 1e3 * v.m_per_px);
  return 0;
}

}  // namespace

void RegisterTrack(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<TrackOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("track", "track a camera's LEDs in a video into the rig's LED channels (raw CSV)");
  cmd->add_option("video", opts->video,
                  "video file (mp4, mkv, avi...), image pattern (frames/%06d.png), or v4l2:/dev/videoN; "
                  "a leading video: is accepted")
      ->required();
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML) with a [camera.video] section")->required();
  cmd->add_option("--out", opts->out_csv,
                  "raw CSV: time (s), the camera's LED channels (raw units of the rig's channels), and per LED "
                  "<camera>_<led>_area_px, _peak (8-bit), _flags (docs/video.md)")
      ->required();
  cmd->add_option("--frames", opts->max_frames, "stop after this many frames (0: all; a device: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([opts, &run] { run = [opts] { return RunTrack(*opts); }; });
}

}  // namespace rocklab::tools
