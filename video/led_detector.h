#pragma once
/// @file
/// Bright blobs in a region of an 8-bit grey frame, to sub-pixel: pixels
/// above a threshold joined into 8-connected blobs; each blob's centre is
/// the intensity-weighted centroid of (pixel - local background) over its
/// box widened by a margin, the background being the mean of that box's
/// border. For a symmetric spot sampled over +-3 of its sigma this has no
/// pixel-locking bias worth the name (tests/video: below 0.02 px). Each blob
/// keeps its quality: area, peak and saturated pixels.

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace rocklab::video {

struct Blob {
  double u_px{}, v_px{};  ///< centroid: column, row (pixel centres at integers)
  int area_px{};          ///< pixels above the threshold
  int peak{};             ///< brightest pixel, 8-bit level
  int saturated_px{};     ///< pixels at or above the saturation level
  bool oversize{false};   ///< larger than max_area_px: not one LED (merged LEDs, a reflection)
  double flux{};          ///< light above the background over the box, 8-bit levels x px
  /// Standard deviation of the centroid from the pixel noise, px (column,
  /// row): the noise (the variance of the box's border, at least the 1/12
  /// level^2 of 8-bit quantisation) through the centroid's sums
  /// (docs/video.md, "Centroid uncertainty"). 0 for an oversize blob.
  double sigma_u_px{}, sigma_v_px{};
};

struct DetectorOptions {
  std::array<int, 4> roi_px{};  ///< x, y, width, height; width 0 = whole frame
  double threshold{40};         ///< 8-bit level
  int min_area_px{2};
  int max_area_px{2000};
  double saturation{255};
  int margin_px{3};             ///< box widening for the centroid and its background
  int max_blobs{64};            ///< more are counted, not measured
};

struct DetectorCounts {
  int64_t frames{};
  int64_t blobs{};
  int64_t small{};     ///< below min_area_px (noise)
  int64_t oversize{};  ///< above max_area_px
  int64_t too_many{};  ///< frames with more than max_blobs
};

/// No allocation after the first frames of a size (buffers are reused).
class LedDetector {
 public:
  explicit LedDetector(const DetectorOptions& options);
  /// Blobs of `gray` (CV_8UC1) into `out` (cleared first). Never throws.
  void Detect(const cv::Mat& gray, std::vector<Blob>& out);
  const DetectorCounts& counts() const { return counts_; }

 private:
  DetectorOptions o_;
  DetectorCounts counts_;
  cv::Mat mask_, labels_, stats_, centroids_;
};

}  // namespace rocklab::video
