// rocklab_bench_video_tracking: frames per second of LED tracking at 720p
// (docs/video.md, "Measured"). Two figures:
//  1. tracking: blob detection, identification and the plane mapping of
//     in-memory 1280x720 grey frames (4 LEDs, noise), as the video source
//     runs them per frame; wall and CPU time, resident memory at 10% of the
//     run and at its end (flat: nothing grows per frame);
//  2. end to end: an MJPG AVI of the same frames (OpenCV's writer) read by
//     OpenCV's FFmpeg reader (BGR, then grey: the reference), and by the
//     video source's FrameReader (libavcodec, the luma plane) and tracked,
//     on one thread and with the decoding on its own (ReadAhead, as the
//     source does).
// Usage: rocklab_bench_video_tracking [FRAMES] (default 20000).
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "video/frame_reader.h"
#include "video/led_detector.h"
#include "video/led_tracker.h"
#include "video/plane_map.h"

namespace {

using rocklab::video::Blob;
using rocklab::video::LedSample;

constexpr int kWidth = 1280, kHeight = 720;
constexpr int kDistinct = 64;           // frames rendered, then cycled
constexpr double kMmPerPx = 1.0;        // plane scale of the bench's ideal camera
constexpr double kFps = 240;

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_utime.tv_usec * 1e-6 + u.ru_stime.tv_sec + u.ru_stime.tv_usec * 1e-6;
}

long StatusKb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) return std::atol(line.c_str() + std::string(key).size());
  }
  return -1;
}

std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown";
}

// Ideal camera: rig (x, z) m -> pixels, 1 mm/px, origin at the image centre's bottom third.
cv::Point2d ToPx(double x, double z) { return {kWidth / 2.0 + x * 1e3 / kMmPerPx, kHeight * 0.9 - z * 1e3 / kMmPerPx}; }

rocklab::video::VideoConfig Config() {
  rocklab::video::VideoConfig c;
  c.camera = "bench";
  const double leds[4][2] = {{-0.08, 0.15}, {0.08, 0.15}, {-0.08, 0.55}, {0.08, 0.55}};
  for (const auto& l : leds) c.leds.push_back({"L", l[0], l[1], nullptr, nullptr});
  const double marks[4][2] = {{-0.4, 0.0}, {0.4, 0.0}, {-0.4, 0.6}, {0.4, 0.6}};
  for (const auto& m : marks) {
    const cv::Point2d p = ToPx(m[0], m[1]);
    c.marks.push_back({p.x, p.y, m[0], m[1], 0});
  }
  return c;
}

std::vector<cv::Mat> Render(const rocklab::video::VideoConfig& c) {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::vector<cv::Mat> frames;
  for (int k = 0; k < kDistinct; ++k) {
    cv::Mat f(kHeight, kWidth, CV_8U);
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) f.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(std::lround(12 + noise(rng)));
    }
    const double theta = 0.05 * std::sin(2 * M_PI * k / kDistinct);
    for (const auto& led : c.leds) {
      const double px = theta >= 0 ? 0.125 : -0.125, cs = std::cos(-theta), sn = std::sin(-theta);
      const cv::Point2d p = ToPx(px + cs * (led.x_m - px) - sn * led.z_m, sn * (led.x_m - px) + cs * led.z_m);
      for (int y = static_cast<int>(p.y) - 8; y <= static_cast<int>(p.y) + 8; ++y) {
        for (int x = static_cast<int>(p.x) - 8; x <= static_cast<int>(p.x) + 8; ++x) {
          const double d2 = (x - p.x) * (x - p.x) + (y - p.y) * (y - p.y);
          f.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(f.at<uint8_t>(y, x) + 200 * std::exp(-d2 / (2 * 2.0 * 2.0)));
        }
      }
    }
    frames.push_back(f);
  }
  return frames;
}

}  // namespace

int main(int argc, char** argv) {
  const long n = argc > 1 ? std::atol(argv[1]) : 20000;
  if (n < 100) {
    std::fprintf(stderr, "usage: %s [FRAMES >= 100]\n", argv[0]);
    return 2;
  }
  const rocklab::video::VideoConfig config = Config();
  const std::vector<cv::Mat> frames = Render(config);
  rocklab::video::PlaneMap map(std::nullopt, config.marks, "bench");
  rocklab::video::DetectorOptions dopt;
  rocklab::video::LedDetector detector(dopt);
  rocklab::video::LedTracker tracker(config, map);
  std::vector<Blob> blobs;
  std::vector<LedSample> samples;
  std::printf("CPU: %s, %ld online; OpenCV %s, %d threads\n", CpuModel().c_str(), sysconf(_SC_NPROCESSORS_ONLN),
              CV_VERSION, cv::getNumThreads());

  // 1. Tracking of in-memory frames.
  long rss_10 = 0;
  const double cpu0 = CpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (long k = 0; k < n; ++k) {
    detector.Detect(frames[static_cast<std::size_t>(k % kDistinct)], blobs);
    tracker.Track(blobs, k / kFps, samples);
    if (k == n / 10) rss_10 = StatusKb("VmRSS:");
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = CpuSeconds() - cpu0;
  const long rss_end = StatusKb("VmRSS:");
  const auto& tc = tracker.counts();
  std::printf("tracking 1280x720: %ld frames in %.3f s wall, %.3f s CPU: %.0f frames/s wall, %.0f frames per CPU-s; "
              "RSS %ld kB at 10%%, %ld kB at the end; %lld fits, %lld missing, %lld stray blobs\n",
              n, wall, cpu, n / wall, n / cpu, rss_10, rss_end, static_cast<long long>(tc.fits),
              static_cast<long long>(tc.missing_samples), static_cast<long long>(tc.reflections));

  // 2. Decoding an MJPG AVI and tracking.
  char dir_template[] = "/tmp/rocklab_bench_video_XXXXXX";
  if (mkdtemp(dir_template) == nullptr) return 1;
  const std::string path = std::string(dir_template) + "/bench.avi";
  const int written = 600;
  {
    cv::VideoWriter w(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), kFps,
                      cv::Size(kWidth, kHeight), true);
    if (!w.isOpened()) {
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
      return 1;
    }
    // Colour frames: FFmpeg's decoder rejects OpenCV's greyscale MJPEG.
    cv::Mat bgr;
    for (int k = 0; k < written; ++k) {
      cv::cvtColor(frames[static_cast<std::size_t>(k % kDistinct)], bgr, cv::COLOR_GRAY2BGR);
      w.write(bgr);
    }
  }
  std::vector<cv::Point2d> reference_centroids;  // every LED of every frame, px
  {
    // The reference: OpenCV's FFmpeg reader (every frame converted to BGR by
    // swscale) and OpenCV's grey, as FrameReader read files before it
    // decoded them with libavcodec itself; one thread.
    cv::VideoCapture cap(path, cv::CAP_FFMPEG);
    rocklab::video::LedTracker tracker0(config, map);
    cv::Mat bgr, gray;
    long read = 0;
    const double cpu1 = CpuSeconds();
    const auto t1 = std::chrono::steady_clock::now();
    while (cap.read(bgr)) {
      cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
      detector.Detect(gray, blobs);
      tracker0.Track(blobs, cap.get(cv::CAP_PROP_POS_MSEC) * 1e-3, samples);
      for (const LedSample& s : samples) reference_centroids.emplace_back(s.u_px, s.v_px);
      ++read;
    }
    const double wall2 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    const double cpu2 = CpuSeconds() - cpu1;
    std::printf("decode (MJPG, OpenCV's reader, BGR then grey) + tracking 1280x720, one thread: %ld frames in %.3f s "
                "wall, %.3f s CPU: %.0f frames/s wall, %.0f frames per CPU-s; %lld fits\n",
                read, wall2, cpu2, read / wall2, read / cpu2, static_cast<long long>(tracker0.counts().fits));
  }
  for (const bool ahead : {false, true}) {
    rocklab::video::FrameReader reader(path, false, std::nullopt);
    std::unique_ptr<rocklab::video::ReadAhead> read_ahead;
    if (ahead) read_ahead = std::make_unique<rocklab::video::ReadAhead>(reader);
    rocklab::video::LedTracker tracker2(config, map);
    cv::Mat gray;
    double t = 0;
    int64_t number = 0;
    long read = 0;
    std::size_t compared = 0;
    double worst_px = 0;  // the largest centroid difference from the reference's
    bool all_found = true;
    const double cpu1 = CpuSeconds();
    const auto t1 = std::chrono::steady_clock::now();
    while (ahead ? read_ahead->Next(gray, t, number) : reader.Next(gray, t, number)) {
      detector.Detect(gray, blobs);
      tracker2.Track(blobs, t, samples);
      for (const LedSample& s : samples) {
        if (compared < reference_centroids.size()) {
          const cv::Point2d& r = reference_centroids[compared++];
          worst_px = std::max({worst_px, std::abs(s.u_px - r.x), std::abs(s.v_px - r.y)});
          all_found = all_found && std::isfinite(s.u_px) == std::isfinite(r.x);
        }
      }
      ++read;
    }
    const double wall2 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    const double cpu2 = CpuSeconds() - cpu1;
    std::printf("decode (MJPG, libavcodec's luma) + tracking 1280x720, %s: %ld frames in %.3f s wall, %.3f s CPU: "
                "%.0f frames/s wall, %.0f frames per CPU-s; %lld fits (MJPEG: two decoding threads)\n",
                ahead ? "decoding on its own thread (ReadAhead)" : "tracking on the reading thread", read, wall2, cpu2,
                read / wall2, read / cpu2, static_cast<long long>(tracker2.counts().fits));
    std::printf("  centroids against OpenCV's reader's: %zu LED samples, largest difference %.3g px, %s\n", compared,
                worst_px, all_found ? "the same LEDs found" : "NOT the same LEDs found");
  }
  std::filesystem::remove_all(dir_template);
  return 0;
}
