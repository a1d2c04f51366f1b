#pragma once
/// @file
/// Table motions that drive the models: analytic sines (docs/errata.md item 11) and
/// sampled acceleration records.

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rocklab::model {

/// The table acceleration u_g''(t) seen by a model. The models apply the
/// inertial acceleration a = -u_g'' to the block (docs/errata.md item 5).
class Forcing {
 public:
  virtual ~Forcing() = default;
  /// Table acceleration u_g'' at time t_s (s), m/s^2.
  virtual double TableAcceleration(double t_s) const = 0;
  /// The first time strictly after t_s (s) where u_g'' may jump (the end of
  /// a motion or of a record), +infinity when there is none. The models stop
  /// their integrator there and restart it on the other side, so a jump is
  /// never integrated across. Where a forcing jumps without saying so, the
  /// integrator still recovers (it restarts where its error test failed),
  /// at a higher cost. At a jump time the value may be either side's.
  virtual double NextDiscontinuity(double /*t_s*/) const {
    return std::numeric_limits<double>::infinity();
  }
  /// The table displacement u_g at t_s (s), m, when the forcing knows it in
  /// closed form (an Excitation); nullopt otherwise (a record, or a sum
  /// holding one: integrate the acceleration, as TableMotion does).
  virtual std::optional<double> ExactDisplacement(double /*t_s*/) const { return std::nullopt; }
};

/// No table motion: u_g'' = 0 everywhere (free rocking).
class NoTableMotion final : public Forcing {
 public:
  double TableAcceleration(double) const override { return 0.0; }
};

/// A table motion known in closed form: displacement and its exact derivatives.
/// Its acceleration may jump at the start and the end of the motion (they
/// are its discontinuities).
class Excitation : public Forcing {
 public:
  virtual double Displacement(double t_s) const = 0;  ///< m
  virtual double Velocity(double t_s) const = 0;      ///< m/s
  std::optional<double> ExactDisplacement(double t_s) const override { return Displacement(t_s); }
};

/// The largest table acceleration a sine excitation may reach, m/s^2
/// (1e5 g: no table or earthquake comes within four orders of it; beyond
/// it, and at overflow, the spec is refused rather than run on inf).
inline constexpr double kMaxTableAccel = 1e6;

/// Parameters of a sine table motion.
struct SineSpec {
  double amplitude_m{};   ///< displacement amplitude U, m; >= 0
  double frequency_hz{};  ///< f, Hz; > 0
  double duration_s{};    ///< length of the motion, s; > 0
  double start_s{};       ///< time the motion starts, s; >= 0
  /// @throws std::invalid_argument naming the key (amp, freq, duration, start),
  ///         or amp and freq when the acceleration would pass kMaxTableAccel.
  void Validate() const;
};

/// u(t) = U sin(2 pi f (t - start)) on [start, start + duration], zero
/// outside. The velocity jumps at the ends (the table starts abruptly); the
/// acceleration is the exact second derivative inside and zero outside.
std::unique_ptr<Excitation> MakeSine(const SineSpec& spec);

/// u(t) = U A(t - t_c) sin(2 pi f (t - start)) with the Hanning window
/// A(x) = (1 + cos(pi x / a)) / 2 of half-duration a = duration / 2 centred on
/// t_c = start + a (paper footnote 4, docs/errata.md item 11). Displacement, velocity
/// and acceleration are exact and continuous.
std::unique_ptr<Excitation> MakeHanningSine(const SineSpec& spec);

/// Sum of several excitations (the CLI accepts --excitation more than once).
std::unique_ptr<Excitation> MakeSum(std::vector<std::unique_ptr<Excitation>> parts);

/// Sum of several forcings of any kind (excitations and records together).
/// @throws std::invalid_argument when a part is null.
std::unique_ptr<Forcing> MakeForcingSum(std::vector<std::unique_ptr<Forcing>> parts);

/// Parses `sine:amp=0.006,freq=5,duration=20,start=0` or
/// `hanning:amp=0.006,freq=3.3,duration=4,start=0.5` (amp in m, freq in Hz,
/// duration and start in s; start defaults to 0).
/// @throws std::invalid_argument naming the kind or key that is wrong.
std::unique_ptr<Excitation> ParseExcitation(const std::string& spec);

/// How a sampled record is read between its samples (docs/fit_coverage.md
/// compares them on forced fits).
enum class Interpolation {
  /// The chord between neighbouring samples: off a smooth acceleration by
  /// a'' h^2 / 8 mid-interval, a'' h^2 / 12 on average (one sign under each
  /// peak). `simulate --accel` and the model node's default.
  kLinear,
  /// C1 cubic Hermite with centred slopes (a[k+1] - a[k-1]) / (t[k+1] -
  /// t[k-1]), one-sided at the ends (Catmull-Rom on the sample times): exact
  /// for quadratics, off by at most 0.016 h^3 max|a'''| inside, with a mean
  /// of zero over each interval to that order.
  kCatmullRom,
  /// The not-a-knot cubic spline through the samples (C2; natural with 3
  /// samples, the chord with 2): exact for cubics, off by about
  /// 5/384 h^4 max|a''''| inside. What the forced trajectory fit reads.
  kSpline,
};

/// A sampled table-acceleration record, read between samples as
/// `interpolation` says (the chord by default) and zero outside the record.
class SampledAcceleration : public Forcing {
 public:
  /// @param time_s strictly increasing sample times, s
  /// @param accel_mps2 table acceleration at those times, m/s^2, finite
  /// @throws std::invalid_argument on size mismatch, fewer than 2 samples,
  ///         non-increasing time or a non-finite value (naming the index).
  SampledAcceleration(std::vector<double> time_s, std::vector<double> accel_mps2,
                      Interpolation interpolation = Interpolation::kLinear);
  double TableAcceleration(double t_s) const override;
  /// The first and last sample times (where the record starts and stops
  /// against the zero outside it); every interpolation is continuous inside.
  double NextDiscontinuity(double t_s) const override;
  double start_s() const { return time_.front(); }
  double end_s() const { return time_.back(); }
  Interpolation interpolation() const { return interpolation_; }

 private:
  double CatmullRomSlope(std::size_t i) const;  // m/s^3 at sample i

  std::vector<double> time_;
  std::vector<double> accel_;
  Interpolation interpolation_;
  std::vector<double> curvature_;  // kSpline: the spline's a'' at each sample, m/s^4
};

/// The newest samples of a table-acceleration stream as a forcing: the model
/// node's lookahead window (ModelNodeConfig::lookahead_samples). A fixed ring
/// of `capacity` samples (the oldest are dropped): no allocation after
/// construction. Before the first sample u_g'' holds the first sample's value;
/// between samples it is the shape's interpolant. horizon_s() is how far the
/// held samples fix that interpolant: pushing a sample never changes it before
/// the horizon, so a model integrated up to the horizon stays valid.
/// docs/models.md compares the shapes and says which the node uses.
class SampleWindow final : public Forcing {
 public:
  enum class Shape {
    /// The chord between neighbouring samples (as RockingModel::Step):
    /// fixed up to the newest sample.
    kLinear,
    /// C1 cubic Hermite with centred slopes (a[i+1] - a[i-1]) / (t[i+1] -
    /// t[i-1]) (Catmull-Rom on non-uniform times; the chord's slope at the
    /// stream's first sample): the slope at a sample needs the next one, so
    /// it is fixed up to the sample before the newest; once Close()d, the
    /// last interval is the chord.
    kCubic,
  };
  /// @param capacity samples held, >= 4. Evaluating before the oldest held
  ///        sample's interval is the caller's error (the node holds its
  ///        lookahead plus 8).
  /// @throws std::invalid_argument for capacity < 4.
  SampleWindow(int capacity, Shape shape);
  /// Forgets every sample and reopens the window.
  void Clear();
  /// Appends a sample: t_s (s) after the newest sample, accel finite
  /// (m/s^2). The caller guarantees both (the node checks them first); a
  /// violation is ignored and returns false.
  [[nodiscard]] bool Push(double t_s, double accel_mps2);
  /// No sample follows until Clear(): the interpolant is fixed up to the
  /// newest sample (kCubic: its last interval becomes the chord).
  void Close() { closed_ = true; }
  /// s; -infinity while empty.
  double horizon_s() const;
  double TableAcceleration(double t_s) const override;
  int size() const { return size_; }
  Shape shape() const { return shape_; }

 private:
  // Held index i (0 oldest) -> ring slot; the ring stores every sample twice
  // (slot and slot + capacity), so the held samples are contiguous.
  const double* times() const { return time_.data() + first_; }
  const double* accels() const { return accel_.data() + first_; }
  double Slope(int i) const;  // kCubic slope at held sample i, m/s^3

  Shape shape_;
  int capacity_;
  std::vector<double> time_, accel_;  // 2 * capacity each
  int first_{};   // slot of the oldest held sample
  int size_{};
  bool closed_{};
};

/// The rows of a `time,accel` CSV, as read.
struct AccelerationRows {
  std::vector<double> time_s;      ///< s, finite, strictly increasing
  std::vector<double> accel_mps2;  ///< table acceleration, m/s^2, finite
  std::vector<std::int64_t> line;  ///< the file's line of each row (from 1)
};

/// Reads a table-acceleration file: the one reader of them (`simulate
/// --accel`, `synth --accel`, `fit --accel`, `sweep`). A PEER NGA record
/// (.AT2 by extension, or any file whose fourth line names NPTS and DT): four
/// header lines, NPTS and DT in either style, NPTS values in g (any number
/// to a line), sample k at k DT s, converted to m/s^2 with g = 9.81;
/// .VT2/.DT2 (velocity, displacement) are refused, and so is an NPTS that
/// disagrees with the values. Otherwise a CSV with the header `time,accel`
/// (s, m/s^2). Blank lines
/// and lines starting with '#' are skipped, the first other line is the
/// header, fields may carry surrounding blanks, then every row is two
/// finite numbers with time strictly increasing; at least 2 rows.
/// @throws std::runtime_error "FILE:LINE: ..." for the first problem (bad
///         input quoted, escaped and bounded).
AccelerationRows ReadAccelerationRows(const std::string& path);

/// ReadAccelerationRows as a forcing.
/// @throws std::runtime_error as ReadAccelerationRows.
SampledAcceleration ReadAccelerationCsv(const std::string& path);

}  // namespace rocklab::model
