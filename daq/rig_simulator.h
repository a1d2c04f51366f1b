#pragma once
/// @file
/// The inverse of the measurement models: from the block's true motion to the
/// raw channel values the rig would acquire, with seeded noise, LED
/// occlusions and dropped samples. Drives `rocklab synth` and the daq tests.

#include <array>
#include <cstdint>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "daq/rig_config.h"

namespace rocklab::daq {

/// The true motion at one sample. Faults are the block's departure from pure
/// rocking, applied to the pivot and to the out-of-plane LEDs.
struct TrueMotion {
  double time_s{};              ///< s
  double theta{};               ///< rad, > 0 about the +x corner
  double table_displacement{};  ///< m
  double table_acceleration{};  ///< u_g'', m/s^2
  double slip_m{};              ///< pivot displacement along x relative to the table, m
  double lift_m{};              ///< pivot lift, m
  double twist_rad{};           ///< rotation about the vertical, rad
  double out_of_plane_m{};      ///< out-of-plane translation, m
  double tilt_rad{};            ///< out-of-plane tilt seen by the mirror, rad
  /// A multi-body rig (RigConfig::multi_body()): every body's absolute
  /// angle, rad, bottom-up (theta above is not read). Each body rocks on
  /// the corner of its contact face that its angle relative to the body
  /// below leans to; slip_m and lift_m then displace the pivot of body
  /// `slip_body` along and off the face below it (0: the table), carrying
  /// the bodies above with it.
  std::array<double, kMaxRigBodies> body_theta{};
  int slip_body{0};
  /// A multi-body rig: the body that twists by twist_rad (0: the bottom
  /// one); the bodies above turn with it (as they go with a slide), so the
  /// out-of-plane pair of every body from it up reads the twist, those
  /// below none. A single block: not read.
  int twist_body{0};
};

/// Noise and imperfections, physical units (standard deviations).
struct SimulatorNoise {
  double led_m{};          ///< each LED coordinate, m
  double mirror_m{};       ///< each mirror spot coordinate, m
  double oop_m{};          ///< each out-of-plane LED coordinate, m
  double table_m{};        ///< table displacement, m
  double accel_mps2{};     ///< accelerometer, m/s^2
  double occlusion{};      ///< probability that an LED is hidden at a sample (NaN x and z)
  double drop{};           ///< probability that a whole sample is lost
  /// Scales every standard deviation (the --noise-scale of `rocklab synth`).
  SimulatorNoise Scaled(double factor) const;
  /// Typical figures of the lab's rig: 0.2 mm LEDs, 0.1 mm mirror spot,
  /// 0.1 mm out-of-plane, 20 um table, 0.05 m/s^2 accelerometer, 1 %
  /// occlusions, 0.1 % drops.
  static SimulatorNoise Typical();
};

class RigSimulator {
 public:
  /// @throws std::invalid_argument when a probability is outside [0, 1) or a
  ///         standard deviation is negative.
  RigSimulator(const RigConfig& rig, const SimulatorNoise& noise, uint64_t seed);

  /// Channel names in the order Raw() fills them (the rig's [[channel]] order).
  const std::vector<std::string>& channel_names() const { return names_; }

  /// Raw values of one sample into `raw` (resized to the channel count).
  /// Returns false when the sample is dropped (nothing should be written).
  bool Raw(const TrueMotion& motion, std::vector<double>& raw);

  /// Exact physical value of a sensor for `motion` (no noise), in the
  /// channel's unit. Tests use it as the forward model's inverse oracle.
  double Physical(const std::string& sensor, const TrueMotion& motion) const;

  /// Where the point (x, z) of body k's frame (origin at its base centre,
  /// m) is in the rig frame for `motion` of a multi-body rig, m.
  void BodyPoint(const TrueMotion& motion, int k, double x_m, double z_m, double& wx_m, double& wz_m) const;

 private:
  RigConfig rig_;
  SimulatorNoise noise_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  std::vector<std::string> names_;
  std::vector<double> sd_;        // per channel, physical unit
  std::vector<int> led_of_;       // per channel: LED index, -1 if not an LED
  std::vector<char> led_hidden_;  // per LED, this sample
};

/// Writes raw samples as CSV (header `time,<channels>`) or LabVIEW .lvm (tab
/// separated, decimal comma optional, X_Value column; a new segment can be
/// started at any sample). Decimal text with 10 significant digits.
class RawFileWriter {
 public:
  enum class Format { kCsv, kLvm };
  /// @throws std::runtime_error when the file cannot be created.
  RawFileWriter(const std::string& path, Format format, std::vector<std::string> channel_names,
                double sample_rate_hz, bool decimal_comma = false);
  /// By extension: .lvm, else CSV.
  static Format FormatOf(const std::string& path);
  void StartSegment(double t0_s, int64_t samples);  ///< LVM: a segment header; CSV: no-op
  void Write(double time_s, const std::vector<double>& values);
  /// Flushes and closes. @throws std::runtime_error on a write error.
  void Close();

 private:
  void Number(double v);
  std::ofstream out_;
  std::string path_;
  Format format_;
  std::vector<std::string> names_;
  double rate_hz_;
  bool decimal_comma_;
  char sep_;
};

}  // namespace rocklab::daq
