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
/// blobs left over are reflections. Each of these is a flag on the sample
/// and a count, and the LED's coordinates are NaN. A saturated LED is
/// measured (the centroid of a clipped symmetric spot stays centred) and
/// flagged.

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
  std::vector<bool> seen_;
  std::vector<cv::Point2d> blob_px_, blob_xz_, pred_;
  std::vector<int> pick_, blob_users_;
  std::vector<double> mx_, mz_, wx_, wz_;
  std::vector<int> used_;
};

}  // namespace rocklab::video
