#pragma once
/// @file
/// Which blob is which LED. The first frames look for the LEDs where the
/// rig's layout puts them at rest (the rig frame is the block frame at rest);
/// afterwards each frame predicts the LEDs from the block's rigid motion
/// (rotation and translation in the plane, constant rates from the last two
/// fits) and takes the blob nearest each prediction within the gate.
/// Nothing is guessed: an LED with no blob in its gate is missing (an
/// occlusion, counted once per episode); one blob claimed by two LEDs makes
/// both merged; two comparable blobs in one gate make the LED ambiguous
/// (a swap could follow); an LED off the rigid fit of the others by more
/// than residual_m is inconsistent (a swap or a reflection taken for it);
/// blobs left over are reflections; a blob whose area or light departs
/// from the LED's running statistics is an outlier (a glint merged with the
/// LED, a partial occlusion: rejected, not averaged). Each of these is a
/// flag on the sample and a count, and the LED's coordinates are NaN. A
/// saturated LED is measured (the centroid of a clipped symmetric spot
/// stays centred) and flagged. With a rolling shutter (SetRowTime) each LED
/// is taken back to the time of the frame's first row along the block's
/// rigid motion (docs/video.md, Time).

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "video/led_detector.h"
#include "video/plane_map.h"
#include "video/video_config.h"

namespace rocklab::video {

enum LedFlag : uint32_t {
  kLedSaturated = 1u << 0,     ///< measured, with clipped pixels
  kLedMissing = 1u << 1,       ///< no blob in the gate
  kLedMerged = 1u << 2,        ///< its blob is another LED's too
  kLedAmbiguous = 1u << 3,     ///< two comparable blobs in the gate
  kLedInconsistent = 1u << 4,  ///< off the rigid fit of the others
  kLedOutlier = 1u << 5,       ///< area or light off the LED's running statistics (a glint merged)
};

/// One LED in one frame.
struct LedSample {
  double x_m{std::numeric_limits<double>::quiet_NaN()};  ///< rig frame, m; NaN unless identified
  double z_m{std::numeric_limits<double>::quiet_NaN()};
  double u_px{std::numeric_limits<double>::quiet_NaN()};  ///< image centroid
  double v_px{std::numeric_limits<double>::quiet_NaN()};
  int area_px{};
  int peak{};
  int saturated_px{};
  uint32_t flags{};
  /// The centroid's standard deviation from the pixel noise on the rig
  /// plane, m (Blob::sigma_u_px, sigma_v_px through the image-to-plane
  /// map's Jacobian at the centroid); NaN unless identified.
  double sigma_x_m{std::numeric_limits<double>::quiet_NaN()};
  double sigma_z_m{std::numeric_limits<double>::quiet_NaN()};
};

struct TrackCounts {
  int64_t frames{};
  int64_t fits{};              ///< frames with a rigid fit (>= 2 LEDs)
  int64_t missing_samples{};   ///< LED-frames missing
  int64_t occlusions{};        ///< episodes: an LED seen, then missing
  int64_t merged{};            ///< LED-frames merged
  int64_t ambiguous{};         ///< LED-frames ambiguous
  int64_t inconsistent{};      ///< LED-frames off the rigid fit (swaps, reflections taken for an LED)
  int64_t reflections{};       ///< blobs no LED took (incl. oversize ones)
  int64_t saturated{};         ///< LED-frames measured with clipped pixels
  int64_t outliers{};          ///< LED-frames rejected: blob area or light off its running statistics
  int64_t held_drops{};        ///< drops from the rigid fit kept on last frame's LED (hysteresis)
  int64_t stat_restarts{};     ///< an LED's blob statistics started again after kReseedS of outliers
};

/// No allocation after the first frame.
class LedTracker {
 public:
  /// `map` is retained (non-owning) and must outlive the tracker.
  LedTracker(const VideoConfig& config, const PlaneMap& map);
  /// Identifies `blobs` (one frame at `time_s`, s) into `out`, one sample per
  /// config LED in order. Never throws.
  void Track(const std::vector<Blob>& blobs, double time_s, std::vector<LedSample>& out);
  const TrackCounts& counts() const { return counts_; }
  /// Rolling shutter: row r of a frame is exposed readout_s x r / height_px
  /// after row 0 (s); 0 (the default): all rows at once.
  void SetRowTime(double readout_s, int height_px) {
    row_time_s_ = height_px > 0 ? readout_s / height_px : 0.0;
  }
  /// The identification radius in use, m.
  double gate_m() const { return gate_m_; }
  /// The block's rotation from the last fit, rad (theta = -phi; NaN before a fit).
  double theta() const { return have_pose_ ? -pose_[0] : std::numeric_limits<double>::quiet_NaN(); }

 private:
  const PlaneMap* map_;
  std::vector<VideoLed> leds_;
  double gate_m_{};
  double residual_m_{};
  TrackCounts counts_;
  bool have_pose_{false};
  bool have_rate_{false};
  double pose_[3]{};  // phi (rad), tx, tz (m): world = R(phi) model + t
  double rate_[3]{};  // per s
  double pose_time_s_{};
  double row_time_s_{0};  // s per image row (rolling shutter)
  // Running statistics of each LED's blob (area, light): Welford's over the
  // first samples, then exponentially weighted.
  struct BlobStats {
    int64_t n{};
    double area_mean{}, area_var{}, flux_mean{}, flux_var{};
    double rejecting_since_s{std::numeric_limits<double>::quiet_NaN()};
  };
  bool Departs(const BlobStats& st, const Blob& b) const;
  static void Learn(BlobStats& st, const Blob& b);
  void Correct(const double pose[3], const double rate[3]);
  std::vector<BlobStats> blob_stats_;
  std::vector<double> rx_, rz_, led_dt_;  // positions as seen, each LED's time after row 0's (s)
  std::vector<bool> seen_, dropped_last_;
  std::vector<cv::Point2d> blob_px_, blob_xz_, pred_;
  std::vector<cv::Point2d> jac_px_, jac_xz_;  // +-0.5 px about each identified centroid, and on the plane
  std::vector<int> pick_, blob_users_;
  std::vector<double> mx_, mz_, wx_, wz_;
  std::vector<int> used_;
};

}  // namespace rocklab::video
