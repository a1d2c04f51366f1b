#pragma once
/// @file
/// The video's clock put on the DAQ's (docs/video.md, "In step with the
/// DAQ"): a sync LED in the camera's view, driven by a DAQ channel, gives
/// on/off edges in both records; the edges are paired and
///
///     t_daq = offset_s + (1 + drift_ppm 1e-6) t_video
///
/// fitted by least squares; then the video's channels are resampled on the
/// DAQ's samples (`rocklab track --daq`). No OpenCV here.

#include <cstdint>
#include <string>
#include <vector>

namespace rocklab::video {

/// A switch of a two-level signal, at the time its light (or voltage)
/// crossed the middle between its levels.
struct SyncEdge {
  double t_s{};
  bool rising{};
};

/// The edges of `level` sampled at times `t_s` (ascending). Its levels are
/// the 10th and 90th percentiles of its finite values, normalised to 0 and
/// 1. Each sample integrates the signal over `exposure_s` centred on its
/// time (0: an instantaneous sample, as a DAQ's). A sample between the
/// levels (3 % to 97 %) is an edge inside its exposure, at the time a
/// linear light gives: start + exposure x (1 - f) rising, start +
/// exposure x f falling (f its normalised level). Otherwise the edge lies
/// somewhere between the end of the last sample's exposure and the start
/// of the next's: its middle (error uniform over that gap, so its standard
/// deviation is gap / sqrt(12)). Samples further apart than `max_gap_s`
/// (a drop) give no edge. `contrast` receives high - low.
std::vector<SyncEdge> FindSyncEdges(const std::vector<double>& t_s, const std::vector<double>& level,
                                    double exposure_s, double max_gap_s, double* contrast);

/// The fit of the DAQ's clock against the video's.
struct ClockFit {
  double offset_s{};          ///< DAQ time of the video's time 0, s
  double drift_ppm{};         ///< the DAQ's clock runs (1 + drift) times the video's, 1e-6
  double offset_se_s{};       ///< standard errors, from the residuals
  double drift_se_ppm{};
  double residual_rms_s{};    ///< of the paired edges about the fit, s
  double residual_max_s{};
  double expected_rms_s{};    ///< what the frame and DAQ periods allow per edge, s
  int video_edges{}, daq_edges{}, matched{};
  double DaqTime(double t_video_s) const { return offset_s + (1 + 1e-6 * drift_ppm) * t_video_s; }
  double VideoTime(double t_daq_s) const { return (t_daq_s - offset_s) / (1 + 1e-6 * drift_ppm); }
};

/// Fastest drift the pairing allows for, 1e-6 (a crystal is within 100).
inline constexpr double kMaxSyncDriftPpm = 1000;

/// Pairs `video` edges (video clock) with `daq` edges (DAQ clock) of the
/// same sense and fits the clock. The pairing tries each DAQ edge against
/// the first video edges and keeps the offset most edges agree on (within
/// a frame and a DAQ period, + kMaxSyncDriftPpm of the distance); the
/// LED must be driven irregularly, so that no other offset does nearly as
/// well. `frame_period_s`, `exposure_s`, `daq_period_s` set the tolerances
/// and expected_rms_s; `what` names the two files in errors.
/// @throws std::runtime_error naming them: fewer than 4 edges paired, fewer
///   than 80 % of the video's edges inside the DAQ record paired, another
///   offset nearly as good (a periodic drive), or a residual larger than a
///   frame and a DAQ period together (the edges cannot be that far off).
ClockFit FitClock(const std::vector<SyncEdge>& video, const std::vector<SyncEdge>& daq, double frame_period_s,
                  double exposure_s, double daq_period_s, const std::string& what);

/// What FitClockByMotion measured besides the clock.
struct MotionFit {
  ClockFit clock;              ///< offset, drift and their standard errors; no edges
  double correlation{};        ///< of the video's motion with the DAQ's at the clock found
  double scale{};              ///< video motion per DAQ unit (1 for metres against metres)
  double residual_rms{};       ///< of the video's motion about the fit, its unit
  int samples{};               ///< video samples used
};

/// The clocks from the table's motion (`sync = "table"`): `x_video` (the
/// table's displacement seen in the video, at video times `t_video`, NaN
/// where not seen) against `x_daq` (the DAQ's table displacement at its
/// times `t_daq`, read as the chord between them). Fitted by Gauss-Newton:
/// x_video(t) = scale D(offset + (1 + drift) t) + level, from the offset of
/// the best correlation over every offset that keeps the video inside the
/// DAQ record (steps of a DAQ period). Standard errors from the residuals
/// (s^2 (J^T J)^-1, s^2 = RSS / (n - 4)).
/// @throws std::runtime_error naming `what`: fewer than 20 video samples, a
///   DAQ record shorter than the video, a correlation below 0.9 (no motion
///   seen, or not the table's), another offset correlating within 1 % of
///   the best (a periodic motion: ambiguous), or a drift beyond 1000 ppm.
MotionFit FitClockByMotion(const std::vector<double>& t_video, const std::vector<double>& x_video,
                           const std::vector<double>& t_daq, const std::vector<double>& x_daq,
                           double daq_period_s, const std::string& what);

/// How a video channel is carried onto the DAQ's samples.
enum class Resample {
  kLinear,   ///< between the two frames around the sample (coordinates, sigmas)
  kNearest,  ///< the nearer frame's (areas, peaks, levels)
  kFlags,    ///< the nearer frame's; 2 (missing) where kLinear gives NaN for a gap
};

/// A record in memory: times and one row of values per sample.
struct Record {
  std::vector<std::string> names;
  std::vector<double> t_s;
  std::vector<std::vector<double>> rows;
};

/// What the merge counted.
struct MergeCounts {
  int64_t rows{};      ///< rows written (DAQ samples, or grid points)
  int64_t before{};    ///< DAQ samples before the video's first frame (left out)
  int64_t after{};     ///< after its last (left out)
  int64_t in_gaps{};   ///< rows between frames more than 1.5 frame periods apart (video NaN)
};

/// The merged record on the DAQ's clock, `daq`'s names then `video`'s
/// (`kinds` per video channel), inside the video's span. With
/// `grid_rate_hz` 0: the DAQ's samples, each with the video's channels at
/// its time (the video's time `fit.VideoTime(t)`). Otherwise a grid at
/// that rate (the camera's) from the first frame's DAQ time, the video's
/// channels at each point and the DAQ's channels as the least-squares chord
/// of their own: the values whose chord between the grid's points is
/// nearest (in the integral of the squared difference) to the DAQ's chord
/// between its samples, so that a reader drawing the chord (the model, the
/// fit) gets the table's motion and not one cut below its peaks by
/// a'' h^2 / 8 (NaN where the DAQ record does not cover the grid or has a
/// non-finite sample next to the point).
/// @throws std::runtime_error when a video channel's name is one of the DAQ's.
Record MergeOnDaqClock(const Record& daq, const Record& video, const std::vector<Resample>& kinds,
                       const ClockFit& fit, double frame_period_s, double grid_rate_hz, MergeCounts* counts);

}  // namespace rocklab::video
