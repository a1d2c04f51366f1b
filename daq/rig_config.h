#pragma once
/// @file
/// The rig configuration: one TOML file per shake-table set-up (format in
/// docs/acquisition.md). Loaded once at start-up; every error names the file, the
/// line and the key ("rig.toml:12: key 'mirror.lever_m' must be > 0").

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace rocklab::daq {

/// Ranges the rig file is checked against (docs/acquisition.md: rig file).
inline constexpr double kMinSampleRateHz = 1.0;
inline constexpr double kMaxSampleRateHz = 100000.0;
/// Largest differentiator half window m, samples (a 2001-sample window).
inline constexpr int kMaxHalfWindowSamples = 1000;
inline constexpr int kMaxDifferentiatorOrder = 6;

/// A raw channel and how to turn it into a physical value:
/// physical = gain * raw + offset. A raw value is valid when finite and
/// strictly inside (raw_min, raw_max): a sensor at its rail is saturated.
struct ChannelConfig {
  std::string name;    ///< column name in the raw file (CSV/LVM header, RL_DAQ_CONFIG)
  std::string sensor;  ///< role, one of the sensor names in docs/acquisition.md
  double gain{1.0};    ///< physical unit per raw unit
  double offset{0.0};  ///< physical unit
  std::string unit;    ///< physical unit after calibration ("m", "m/s^2")
  /// The unit of the raw values as a raw file states it (LVM Y_Unit_Label);
  /// "" = not said. A file stating another unit is refused (CheckFileUnits).
  std::string raw_unit;
  double raw_min{-std::numeric_limits<double>::infinity()};  ///< raw unit
  double raw_max{std::numeric_limits<double>::infinity()};   ///< raw unit
  int line{};          ///< line of the channel's table in the rig file
  /// The unit of the raw values as far as the rig says: raw_unit, else
  /// `unit` when the calibration is the identity, else "" (not known).
  std::string RawValuesUnit() const {
    if (!raw_unit.empty()) return raw_unit;
    return gain == 1.0 && offset == 0.0 ? unit : std::string();
  }
};

/// An LED on the block's face, in the block frame: origin at the centre of the
/// base, x along the rocking direction, z up, m.
struct LedConfig {
  std::string name;
  double x_m{};  ///< in its body's frame (a multi-body rig: origin at that body's base centre), m
  double z_m{};
  int body{0};   ///< index into RigConfig::bodies (bottom-up); 0 in a single-block rig
};

/// A lateral camera and the LEDs it sees. All cameras are calibrated (by the
/// channel gains and offsets) into the same rig frame: origin at the base
/// centre of the block at rest with the table at zero displacement, x along
/// the rocking direction, z up, m.
struct CameraConfig {
  std::string name;
  std::vector<LedConfig> leds;
};

/// The LED-mirror: theta = 0.5 atan((s - rest_s) / lever).
struct MirrorConfig {
  bool present{false};
  int body{0};        ///< the body carrying the mirror (index into RigConfig::bodies)
  double lever_m{};   ///< optical lever D, m; > 0
  double rest_s_m{};  ///< spot coordinate along the rocking direction at rest, m
  double rest_n_m{};  ///< orthogonal spot coordinate at rest, m
};

/// Two LEDs a known distance apart along the block's x axis whose
/// out-of-plane (y) coordinates are seen by a camera looking along x.
struct OutOfPlaneConfig {
  bool present{false};
  int body{0};           ///< the body carrying the LED pair (index into RigConfig::bodies)
  double spacing_m{};  ///< x distance from LED a to LED b, m; > 0
  /// Its LEDs' sensor roles are role_prefix + ".a" and ".b": "oop" for the
  /// [out_of_plane] table, "oop.BODY" for a [[out_of_plane]] table of body BODY.
  std::string role_prefix{"oop"};
};

/// Savitzky-Golay smoothing differentiator settings.
struct DifferentiatorConfig {
  double window_s{};  ///< span from first to last sample, s: m = round(window_s * rate / 2), 2m+1 samples
  int order{};        ///< polynomial order in [2, 6]; < number of samples in the window
  /// [table] only: the delay at which the fitted polynomial is evaluated, s,
  /// in [0, m / rate] (0: the causal end-point of the window, m / rate: its
  /// centre); round(lag_s * rate) samples. Absent: the centre, or theta_dot's
  /// delay when an accelerometer measures the acceleration (Processor).
  std::optional<double> lag_s;
};

/// Tolerances of the "only rocking" checks.
struct CheckTolerances {
  double sliding_m{0.001};      ///< |pivot x - table displacement|, m
  double jump_m{0.001};         ///< |pivot lift|, m
  double twist_rad{0.01};       ///< |rotation about the vertical|, rad
  double out_of_plane_m{0.002}; ///< |mean out-of-plane displacement of the LED pair|, m
  double tilt_rad{0.01};        ///< |out-of-plane tilt from the mirror's orthogonal spot|, rad
  double disagree_rad{0.005};   ///< |theta_mirror - theta_camera|, rad
  int min_leds{2};              ///< fewest valid LEDs for the rigid fit; >= 2
  /// Noise of the sensors (standard deviation after calibration), and how many
  /// of the predicted standard deviations a tolerance must span for its check
  /// to be made at a sample (else the quantity is reported unmeasured).
  double led_sigma_m{2e-4};     ///< each LED coordinate, m
  double mirror_sigma_m{1e-4};  ///< mirror spot coordinate, m
  double sigmas{5.0};           ///< > 0
};

/// Block geometry (needed for the pivot positions) and optional parameters.
struct BlockConfig {
  double width_m{};    ///< 2b, m
  double height_m{};   ///< 2h, m
  double chamfer_m{};  ///< 45 degree base chamfer leg, m; the pivot is at x = +-(b - chamfer)
  std::optional<double> alpha;  ///< rad; when absent the model library derives it from the geometry
  std::optional<double> p;      ///< rad/s
  std::optional<double> mu;     ///< 1
  /// The section as a polygon when it is not a (chamfered) rectangle:
  /// [x, z] vertices in order, block frame (m), inline in the rig file as
  /// `polygon = [[x, z], ...]`. Empty: the rectangle width_m x height_m with
  /// chamfer_m. The model library derives alpha, p and mu per side from it
  /// (model::PolygonBlock); width_m and height_m still give the box the DAQ's
  /// checks use (pivots at x = +-pivot_half_width_m()).
  std::vector<std::array<double, 2>> polygon_m;
  int polygon_line{};  ///< line of the `polygon` key in the rig file (0: none)
  double pivot_half_width_m() const { return 0.5 * width_m - chamfer_m; }
};

/// Upper limit of a rig's bodies (a column of drums; the stack model's).
inline constexpr int kMaxRigBodies = 8;

/// One body of an assembly rig (`[[body]]`, bottom-up): its name (as the
/// assembly file's) and its rectangular box, whose base corners are the
/// pivots of the checks (docs/acquisition.md, "Assemblies").
struct RigBody {
  std::string name;
  double width_m{};   ///< 2b, m
  double height_m{};  ///< 2h, m
  int line{};         ///< line of its table in the rig file
};

/// Priors of `rocklab fit --posterior` (docs/identification.md), each
/// absent unless the rig file's [posterior] section sets it (the fit's
/// defaults then hold).
struct PosteriorPriorConfig {
  std::optional<double> alpha_band_m;  ///< alpha uniform on the band of b -+ this, m; > 0
  std::optional<double> p_range;       ///< p uniform on geometric p x [1 -+ p_range], 1; in (0, 1)
  std::optional<double> mu_min;        ///< mu uniform on (mu_min, mu_max], 1; 0 <= min < max <= 1
  std::optional<double> mu_max;
  std::optional<double> log10_l_min;   ///< complex model: log10 l uniform on [min, max]; -20 <= min < max <= -2
  std::optional<double> log10_l_max;
  std::optional<double> t_offset_s;    ///< time offset uniform on [-t, t], s; in (0, 1]
  /// Given: a restitution per impact, mu_n ~ N(mu, sigma_mu^2), sigma_mu
  /// uniform on (0, this], 1; in (0, 0.5] (impacts likelihood).
  std::optional<double> sigma_mu_max;
  int line{};                          ///< line of the [posterior] table (0: none)
};

struct RigConfig {
  std::string path;  ///< file it was loaded from
  std::string name;
  std::string calibration_id;
  double sample_rate_hz{};  ///< nominal acquisition rate, Hz; in [kMinSampleRateHz, kMaxSampleRateHz]
  std::vector<ChannelConfig> channels;
  MirrorConfig mirror;
  std::vector<CameraConfig> cameras;
  /// The [out_of_plane] table, or the first [[out_of_plane]] table.
  OutOfPlaneConfig out_of_plane;
  /// Every out-of-plane pair, in the file's order, at most one per body:
  /// [out_of_plane]'s (then it is out_of_plane), or one per [[out_of_plane]]
  /// table (a rig of [[body]] tables: a pair per body, each body's twist).
  std::vector<OutOfPlaneConfig> out_of_plane_pairs;
  BlockConfig block;
  /// `[[body]]` tables bottom-up: empty in a single-block rig (`[block]`).
  /// A rig with one body is that single block (block = its box); with two or
  /// more the DAQ reconstructs every body (multi_body()), block being the bottom one.
  std::vector<RigBody> bodies;
  PosteriorPriorConfig posterior;
  CheckTolerances checks;
  /// theta_dot from theta (default: 10 ms span, order 2).
  DifferentiatorConfig theta_dot{0.010, 2, std::nullopt};
  /// table velocity and acceleration from the displacement (default: 100 ms span, order 4).
  DifferentiatorConfig table{0.100, 4, std::nullopt};

  /// Two or more bodies: per-body reconstruction, checks per interface.
  bool multi_body() const { return bodies.size() > 1; }
  /// Bodies reconstructed: bodies.size(), or 1 for a single-block rig.
  int body_count() const { return bodies.empty() ? 1 : static_cast<int>(bodies.size()); }
  /// Half-width of the contact face under body k (the pivots' |x| in its
  /// frame), m: the bottom body's pivot half-width, else min(b_k-1, b_k)
  /// (centred bodies, as model/stack.h).
  double contact_half_width_m(int k) const;
  /// Height of body k (2h), m: block.height_m in a single-block rig.
  double body_height_m(int k) const;

  /// The channel with this sensor role, or nullptr.
  const ChannelConfig* FindSensor(const std::string& sensor) const;
  /// Half window in samples of a differentiator at sample_rate_hz.
  int HalfWindow(const DifferentiatorConfig& d) const;
  /// Its lag_s in samples at sample_rate_hz (HalfWindow when lag_s is absent).
  int LagSamples(const DifferentiatorConfig& d) const;
};

/// The units a raw file states for its channels (Source::channel_units(),
/// in `names` order; empty: it states none) against the rig's channels.
/// A channel whose `raw_unit` is set and whose file unit differs: throws
/// std::runtime_error naming the rig file and line, the channel, both
/// units and the file. A channel without `raw_unit`, calibrated by the
/// identity (gain 1, offset 0), whose file unit differs from its `unit`:
/// one warning line returned (the raw values are taken as `unit`). Units
/// are compared as written (after trimming).
std::vector<std::string> CheckFileUnits(const RigConfig& rig, const std::vector<std::string>& names,
                                        const std::vector<std::string>& units, const std::string& source_path);

/// Parses a rig file.
/// @throws std::runtime_error "PATH:LINE: key 'a.b' ..." on a TOML syntax
///         error, a missing or mistyped key, an unknown key, an unknown sensor
///         role, a duplicated channel or sensor, or a value out of range.
RigConfig LoadRigConfig(const std::string& path);
/// Same, from text; `path` only names the source in messages.
RigConfig ParseRigConfig(const std::string& text, const std::string& path);

}  // namespace rocklab::daq
