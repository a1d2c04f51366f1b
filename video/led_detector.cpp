#include "video/led_detector.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace rocklab::video {
namespace {
// 8-bit quantisation's variance, levels^2 (a uniform error of one level).
constexpr double kQuantisationVariance = 1.0 / 12;
}  // namespace

LedDetector::LedDetector(const DetectorOptions& options) : o_(options) {}

void LedDetector::Detect(const cv::Mat& gray, std::vector<Blob>& out) {
  out.clear();
  ++counts_.frames;
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  if (o_.roi_px[2] > 0 && o_.roi_px[3] > 0) {
    roi = cv::Rect(o_.roi_px[0], o_.roi_px[1], o_.roi_px[2], o_.roi_px[3]) & roi;
  }
  if (roi.empty()) return;
  const cv::Mat region = gray(roi);
  // THRESH_BINARY keeps level > threshold.
  cv::threshold(region, mask_, o_.threshold, 255, cv::THRESH_BINARY);
  const int n = cv::connectedComponentsWithStats(mask_, labels_, stats_, centroids_, 8, CV_32S);
  int measured = 0;
  for (int label = 1; label < n; ++label) {
    const int* s = stats_.ptr<int>(label);
    const int area = s[cv::CC_STAT_AREA];
    if (area < o_.min_area_px) {
      ++counts_.small;
      continue;
    }
    if (measured == o_.max_blobs) {
      ++counts_.too_many;
      break;
    }
    ++measured;
    Blob b;
    b.area_px = area;
    // The box widened by the margin, in frame coordinates.
    const cv::Rect box = cv::Rect(s[cv::CC_STAT_LEFT] + roi.x - o_.margin_px, s[cv::CC_STAT_TOP] + roi.y - o_.margin_px,
                                  s[cv::CC_STAT_WIDTH] + 2 * o_.margin_px,
                                  s[cv::CC_STAT_HEIGHT] + 2 * o_.margin_px) &
                         cv::Rect(0, 0, gray.cols, gray.rows);
    if (area > o_.max_area_px) {
      ++counts_.oversize;
      b.oversize = true;
      b.u_px = box.x + 0.5 * (box.width - 1);
      b.v_px = box.y + 0.5 * (box.height - 1);
      out.push_back(b);
      continue;
    }
    // Background: mean of the box's border pixels.
    double border = 0, border2 = 0;
    int border_n = 0;
    for (int y = box.y; y < box.y + box.height; ++y) {
      const uint8_t* row = gray.ptr<uint8_t>(y);
      if (y == box.y || y == box.y + box.height - 1) {
        for (int x = box.x; x < box.x + box.width; ++x) {
          border += row[x];
          border2 += row[x] * row[x];
        }
        border_n += box.width;
      } else {
        const int a = row[box.x], z = row[box.x + box.width - 1];
        border += a + z;
        border2 += a * a + z * z;
        border_n += 2;
      }
    }
    const double bg = border_n > 0 ? border / border_n : 0.0;
    // The pixel noise, levels^2: the border's variance (quantisation
    // included), at least quantisation's 1/12 (a noiseless background).
    const double noise2 =
        std::max(border_n > 1 ? (border2 - border * bg) / (border_n - 1) : 0.0, kQuantisationVariance);
    double sw = 0, su = 0, sv = 0;
    int peak = 0, sat = 0;
    const int sat_level = static_cast<int>(o_.saturation);
    for (int y = box.y; y < box.y + box.height; ++y) {
      const uint8_t* row = gray.ptr<uint8_t>(y);
      double rw = 0, ru = 0;
      for (int x = box.x; x < box.x + box.width; ++x) {
        const int p = row[x];
        peak = std::max(peak, p);
        sat += p >= sat_level ? 1 : 0;
        // Every pixel of the box, below the background too: the estimate
        // stays unbiased under the noise (a clipped weight would pull it
        // towards the box's centre).
        const double w = p - bg;
        rw += w;
        ru += w * x;
      }
      sw += rw;
      su += ru;
      sv += rw * y;
    }
    if (sw <= 0) {  // no light above its surroundings: not a measurable blob, not guessed
      ++counts_.small;
      continue;
    }
    b.u_px = su / sw;
    b.v_px = sv / sw;
    // u = sum w x / sum w, w = p - bg over the N box pixels: white noise of
    // variance s2 on each p gives var(u) = s2 sum (x - u)^2 / (sum w)^2, and
    // the background's error (the border mean of n pixels, variance s2 / n)
    // moves u by N (u - xc) / sum w per level (xc: the box's centre).
    // sum over the box of (x - u)^2 = rows (W (xc - u)^2 + W (W^2 - 1) / 12).
    const auto sigma = [&](double c, double centre, int along, int across) {
      const double w = along;
      const double spread = across * (w * (centre - c) * (centre - c) + w * (w * w - 1) / 12);
      const double shift = static_cast<double>(box.area()) * (c - centre) / sw;
      return std::sqrt(noise2 * (spread / (sw * sw) + shift * shift / std::max(border_n, 1)));
    };
    b.sigma_u_px = sigma(b.u_px, box.x + 0.5 * (box.width - 1), box.width, box.height);
    b.sigma_v_px = sigma(b.v_px, box.y + 0.5 * (box.height - 1), box.height, box.width);
    b.peak = peak;
    b.saturated_px = sat;
    b.flux = sw;
    out.push_back(b);
  }
  counts_.blobs += static_cast<int64_t>(out.size());
}

}  // namespace rocklab::video
