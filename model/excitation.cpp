#include "model/excitation.h"

#include "model/numbers.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "common/cancel.h"
#include "common/text.h"
#include "common/units.h"

namespace rocklab::model {
namespace {

using detail::ExactText;
using detail::kPi;

// The first of start, start + duration strictly after t (+inf when none).
double NextEnd(const SineSpec& s, double t) {
  if (s.start_s > t) return s.start_s;
  const double end = s.start_s + s.duration_s;
  return end > t ? end : std::numeric_limits<double>::infinity();
}

// u = U sin(w (t - start)) on [start, start + duration].
class Sine final : public Excitation {
 public:
  explicit Sine(const SineSpec& s) : s_(s), w_(2 * kPi * s.frequency_hz) {}
  double Displacement(double t) const override {
    return Inside(t) ? s_.amplitude_m * std::sin(w_ * (t - s_.start_s)) : 0.0;
  }
  double Velocity(double t) const override {
    return Inside(t) ? s_.amplitude_m * w_ * std::cos(w_ * (t - s_.start_s)) : 0.0;
  }
  double TableAcceleration(double t) const override {
    return Inside(t) ? -s_.amplitude_m * w_ * w_ * std::sin(w_ * (t - s_.start_s)) : 0.0;
  }
  double NextDiscontinuity(double t) const override { return NextEnd(s_, t); }

 private:
  bool Inside(double t) const { return t >= s_.start_s && t <= s_.start_s + s_.duration_s; }
  SineSpec s_;
  double w_;
};

// u = U A(t - tc) sin(w (t - start)), A(x) = (1 + cos(pi x / a)) / 2 for
// |x| <= a, a = duration / 2, tc = start + a; derivatives by the product rule.
class HanningSine final : public Excitation {
 public:
  explicit HanningSine(const SineSpec& s)
      : s_(s), w_(2 * kPi * s.frequency_hz), a_(s.duration_s / 2), k_(kPi / a_) {}
  double Displacement(double t) const override {
    if (!Inside(t)) return 0.0;
    return s_.amplitude_m * Window(t) * std::sin(w_ * (t - s_.start_s));
  }
  double Velocity(double t) const override {
    if (!Inside(t)) return 0.0;
    const double ph = w_ * (t - s_.start_s);
    return s_.amplitude_m * (WindowD1(t) * std::sin(ph) + Window(t) * w_ * std::cos(ph));
  }
  double TableAcceleration(double t) const override {
    if (!Inside(t)) return 0.0;
    const double ph = w_ * (t - s_.start_s);
    return s_.amplitude_m * (WindowD2(t) * std::sin(ph) + 2 * WindowD1(t) * w_ * std::cos(ph) -
                             Window(t) * w_ * w_ * std::sin(ph));
  }
  // The window's second derivative is pi^2 / (2 a^2) at both ends: the
  // acceleration jumps there unless sin(ph) happens to vanish.
  double NextDiscontinuity(double t) const override { return NextEnd(s_, t); }

 private:
  bool Inside(double t) const { return t >= s_.start_s && t <= s_.start_s + s_.duration_s; }
  double X(double t) const { return t - (s_.start_s + a_); }
  double Window(double t) const { return 0.5 * (1 + std::cos(k_ * X(t))); }
  double WindowD1(double t) const { return -0.5 * k_ * std::sin(k_ * X(t)); }
  double WindowD2(double t) const { return -0.5 * k_ * k_ * std::cos(k_ * X(t)); }
  SineSpec s_;
  double w_;
  double a_;  // half-duration, s
  double k_;  // pi / a, rad/s
};

// The sum of `Part`s as a `Base`: u_g'' adds, and the next jump is the
// earliest of the parts'. Serves both the excitation sum (which adds the
// displacements and velocities too) and the forcing sum.
template <class Base, class Part>
class SumOf : public Base {
 public:
  explicit SumOf(std::vector<std::unique_ptr<Part>> parts) : parts_(std::move(parts)) {}
  double TableAcceleration(double t) const override {
    double s = 0.0;
    for (const auto& p : parts_) s += p->TableAcceleration(t);
    return s;
  }
  double NextDiscontinuity(double t) const override {
    double next = std::numeric_limits<double>::infinity();
    for (const auto& p : parts_) next = std::min(next, p->NextDiscontinuity(t));
    return next;
  }

 protected:
  std::vector<std::unique_ptr<Part>> parts_;
};

class Sum final : public SumOf<Excitation, Excitation> {
 public:
  using SumOf::SumOf;
  double Displacement(double t) const override {
    double s = 0.0;
    for (const auto& p : parts_) s += p->Displacement(t);
    return s;
  }
  double Velocity(double t) const override {
    double s = 0.0;
    for (const auto& p : parts_) s += p->Velocity(t);
    return s;
  }
};

template <class Part>
void RequireParts(const char* who, const std::vector<std::unique_ptr<Part>>& parts) {
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (!parts[i]) throw std::invalid_argument(std::string(who) + ": parts[" + std::to_string(i) + "] is null");
  }
}

}  // namespace

void SineSpec::Validate() const {
  auto bad = [](const char* key, const char* rule, double v) {
    throw std::invalid_argument(std::string("excitation ") + key + " must be " + rule + " (got " +
                                ExactText(v) + ")");
  };
  if (!std::isfinite(amplitude_m) || amplitude_m < 0.0) bad("amp", "finite and >= 0 m", amplitude_m);
  if (!std::isfinite(frequency_hz) || frequency_hz <= 0.0) bad("freq", "finite and > 0 Hz", frequency_hz);
  if (!std::isfinite(duration_s) || duration_s <= 0.0) bad("duration", "finite and > 0 s", duration_s);
  if (!std::isfinite(start_s) || start_s < 0.0) bad("start", "finite and >= 0 s", start_s);
  // The table acceleration must be a number: |u''| <= U (w + pi/a)^2 for the
  // Hanning window of half-length a (|A'| <= pi/2a, |A''| <= pi^2/2a^2), a
  // bound on the plain sine too. 1e308 m gave inf, then "never uplifts".
  const double w = 2.0 * kPi * frequency_hz, a = 0.5 * duration_s;
  const double peak = amplitude_m * (w + kPi / a) * (w + kPi / a);
  if (!std::isfinite(peak) || peak > kMaxTableAccel) {
    throw std::invalid_argument("excitation amp " + ExactText(amplitude_m) + " m at freq " + ExactText(frequency_hz) +
                                " Hz: the table acceleration would reach " + ExactText(peak) +
                                " m/s^2, beyond the " + ExactText(kMaxTableAccel) + " m/s^2 a model can take");
  }
}

std::unique_ptr<Excitation> MakeSine(const SineSpec& spec) {
  spec.Validate();
  return std::make_unique<Sine>(spec);
}

std::unique_ptr<Excitation> MakeHanningSine(const SineSpec& spec) {
  spec.Validate();
  return std::make_unique<HanningSine>(spec);
}

std::unique_ptr<Excitation> MakeSum(std::vector<std::unique_ptr<Excitation>> parts) {
  RequireParts("MakeSum", parts);
  return std::make_unique<Sum>(std::move(parts));
}

std::unique_ptr<Forcing> MakeForcingSum(std::vector<std::unique_ptr<Forcing>> parts) {
  RequireParts("MakeForcingSum", parts);
  return std::make_unique<SumOf<Forcing, Forcing>>(std::move(parts));
}

std::unique_ptr<Excitation> ParseExcitation(const std::string& spec) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos) {
    throw std::invalid_argument("excitation '" + spec +
                                "' must read KIND:amp=..,freq=..,duration=..[,start=..] "
                                "(KIND sine or hanning)");
  }
  const std::string kind(common::Trim(spec.substr(0, colon)));
  if (kind != "sine" && kind != "hanning") {
    throw std::invalid_argument("unknown excitation kind '" + kind + "' in '" + spec +
                                "' (expected sine, hanning)");
  }
  std::map<std::string, double> values;
  std::stringstream items(spec.substr(colon + 1));
  std::string item;
  while (std::getline(items, item, ',')) {
    const auto eq = item.find('=');
    const std::string key(common::Trim(item.substr(0, eq)));
    if (key != "amp" && key != "freq" && key != "duration" && key != "start") {
      throw std::invalid_argument("unknown excitation key '" + key + "' in '" + spec +
                                  "' (expected amp, freq, duration, start)");
    }
    if (eq == std::string::npos) {
      throw std::invalid_argument("excitation key '" + key + "' in '" + spec + "' has no value");
    }
    const std::string text(common::Trim(item.substr(eq + 1)));
    double v = 0.0;
    if (!common::ParseDouble(text, v)) {
      throw std::invalid_argument("excitation key '" + key + "' in '" + spec + "': '" + text +
                                  "' is not a number");
    }
    if (!values.emplace(key, v).second) {
      throw std::invalid_argument("excitation key '" + key + "' given twice in '" + spec + "'");
    }
  }
  for (const char* required : {"amp", "freq", "duration"}) {
    if (values.count(required) == 0) {
      throw std::invalid_argument("excitation '" + spec + "' is missing key '" + required + "'");
    }
  }
  SineSpec s;
  s.amplitude_m = values["amp"];
  s.frequency_hz = values["freq"];
  s.duration_s = values["duration"];
  s.start_s = values.count("start") ? values["start"] : 0.0;
  return kind == "sine" ? MakeSine(s) : MakeHanningSine(s);
}

namespace {

// The second derivatives M at the samples of the not-a-knot cubic spline
// through (t, a): a' continuous at each inner sample,
//   h0 M[i-1] + 2 (h0 + h1) M[i] + h1 M[i+1] = 6 ((a[i+1] - a[i]) / h1 - (a[i] - a[i-1]) / h0),
// and the third derivative continuous at the second and the last but one
// sample (M[0] and M[n-1] eliminated into the first and last rows), solved
// by the Thomas algorithm. 3 samples: the natural spline (M = 0 at the
// ends); 2: the chord (M = 0).
std::vector<double> NotAKnotSplineCurvature(const std::vector<double>& t, const std::vector<double>& a) {
  const std::size_t n = t.size();
  std::vector<double> m(n, 0.0);
  if (n < 3) return m;
  auto h = [&t](std::size_t i) { return t[i + 1] - t[i]; };
  auto rhs = [&](std::size_t i) { return 6.0 * ((a[i + 1] - a[i]) / h(i) - (a[i] - a[i - 1]) / h(i - 1)); };
  if (n == 3) {
    m[1] = rhs(1) / (2.0 * (h(0) + h(1)));
    return m;
  }
  // Rows i = 1 .. n-2: sub[i] M[i-1] + diag[i] M[i] + sup[i] M[i+1] = r[i].
  std::vector<double> sub(n, 0.0), diag(n, 0.0), sup(n, 0.0), r(n, 0.0);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    sub[i] = h(i - 1);
    diag[i] = 2.0 * (h(i - 1) + h(i));
    sup[i] = h(i);
    r[i] = rhs(i);
  }
  // Not-a-knot at sample 1: M[0] = ((h0 + h1) M[1] - h0 M[2]) / h1; at
  // sample n-2: M[n-1] = ((ha + hb) M[n-2] - hb M[n-3]) / ha (ha, hb the
  // last two intervals).
  const double h0 = h(0), h1 = h(1), ha = h(n - 3), hb = h(n - 2);
  diag[1] += h0 * (h0 + h1) / h1;
  sup[1] -= h0 * h0 / h1;
  diag[n - 2] += hb * (ha + hb) / ha;
  sub[n - 2] -= hb * hb / ha;
  for (std::size_t i = 2; i + 1 < n; ++i) {
    const double f = sub[i] / diag[i - 1];
    diag[i] -= f * sup[i - 1];
    r[i] -= f * r[i - 1];
  }
  m[n - 2] = r[n - 2] / diag[n - 2];
  for (std::size_t i = n - 2; i-- > 1;) m[i] = (r[i] - sup[i] * m[i + 1]) / diag[i];
  m[0] = ((h0 + h1) * m[1] - h0 * m[2]) / h1;
  m[n - 1] = ((ha + hb) * m[n - 2] - hb * m[n - 3]) / ha;
  return m;
}

}  // namespace

SampledAcceleration::SampledAcceleration(std::vector<double> time_s, std::vector<double> accel_mps2,
                                         Interpolation interpolation)
    : time_(std::move(time_s)), accel_(std::move(accel_mps2)), interpolation_(interpolation) {
  if (time_.size() != accel_.size()) {
    throw std::invalid_argument("SampledAcceleration: time_s has " + std::to_string(time_.size()) +
                                " samples but accel_mps2 has " + std::to_string(accel_.size()));
  }
  if (time_.size() < 2) {
    throw std::invalid_argument("SampledAcceleration: needs at least 2 samples (got " +
                                std::to_string(time_.size()) + ")");
  }
  for (std::size_t i = 0; i < time_.size(); ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    if (!std::isfinite(time_[i])) throw std::invalid_argument("SampledAcceleration: time_s" + at + " is not finite");
    if (!std::isfinite(accel_[i])) {
      throw std::invalid_argument("SampledAcceleration: accel_mps2" + at + " is not finite");
    }
    if (i > 0 && !(time_[i] > time_[i - 1])) {
      throw std::invalid_argument("SampledAcceleration: time_s" + at + " = " + ExactText(time_[i]) +
                                  " is not after the previous sample");
    }
  }
  if (interpolation_ == Interpolation::kSpline) curvature_ = NotAKnotSplineCurvature(time_, accel_);
}

double SampledAcceleration::CatmullRomSlope(std::size_t i) const {
  const std::size_t lo = i == 0 ? 0 : i - 1, hi = std::min(i + 1, time_.size() - 1);
  return (accel_[hi] - accel_[lo]) / (time_[hi] - time_[lo]);
}

double SampledAcceleration::TableAcceleration(double t_s) const {
  if (!(t_s >= time_.front() && t_s <= time_.back())) return 0.0;
  // First sample strictly after t_s (or the last one).
  auto it = std::upper_bound(time_.begin(), time_.end(), t_s);
  if (it == time_.end()) return accel_.back();
  const std::size_t i = static_cast<std::size_t>(it - time_.begin());
  const double h = time_[i] - time_[i - 1];
  const double w = (t_s - time_[i - 1]) / h;
  const double a0 = accel_[i - 1], a1 = accel_[i];
  switch (interpolation_) {
    case Interpolation::kLinear:
      break;
    case Interpolation::kCatmullRom: {
      const double w2 = w * w, w3 = w2 * w;
      return (2 * w3 - 3 * w2 + 1) * a0 + (w3 - 2 * w2 + w) * h * CatmullRomSlope(i - 1) +
             (-2 * w3 + 3 * w2) * a1 + (w3 - w2) * h * CatmullRomSlope(i);
    }
    case Interpolation::kSpline: {
      // The chord plus what the curvatures M0, M1 at the ends add:
      // -w (1 - w) h^2 / 6 ((2 - w) M0 + (1 + w) M1).
      const double m0 = curvature_[i - 1], m1 = curvature_[i];
      return a0 + w * (a1 - a0) - w * (1 - w) * h * h / 6.0 * ((2 - w) * m0 + (1 + w) * m1);
    }
  }
  return a0 + w * (a1 - a0);
}

double SampledAcceleration::NextDiscontinuity(double t_s) const {
  if (time_.front() > t_s) return time_.front();
  if (time_.back() > t_s) return time_.back();
  return std::numeric_limits<double>::infinity();
}

SampleWindow::SampleWindow(int capacity, Shape shape) : shape_(shape), capacity_(capacity) {
  if (capacity < 4) throw std::invalid_argument("SampleWindow: capacity must be >= 4");
  time_.assign(2 * static_cast<std::size_t>(capacity), 0.0);
  accel_.assign(2 * static_cast<std::size_t>(capacity), 0.0);
}

void SampleWindow::Clear() {
  first_ = size_ = 0;
  closed_ = false;
}

bool SampleWindow::Push(double t_s, double accel_mps2) {
  if (!std::isfinite(t_s) || !std::isfinite(accel_mps2)) return false;
  if (size_ > 0 && !(t_s > times()[size_ - 1])) return false;
  if (size_ == capacity_) {  // drop the oldest
    first_ = (first_ + 1) % capacity_;
    --size_;
  }
  const int slot = (first_ + size_) % capacity_;
  time_[slot] = time_[slot + capacity_] = t_s;
  accel_[slot] = accel_[slot + capacity_] = accel_mps2;
  ++size_;
  return true;
}

double SampleWindow::horizon_s() const {
  if (size_ == 0) return -std::numeric_limits<double>::infinity();
  if (shape_ == Shape::kLinear || closed_ || size_ == 1) return times()[size_ - 1];
  return times()[size_ - 2];
}

double SampleWindow::Slope(int i) const {
  const double* t = times();
  const double* a = accels();
  if (i > 0 && i + 1 < size_) return (a[i + 1] - a[i - 1]) / (t[i + 1] - t[i - 1]);
  // The stream's first sample (or, never in the node, the oldest held one):
  // the chord's slope.
  if (i + 1 < size_) return (a[i + 1] - a[i]) / (t[i + 1] - t[i]);
  return (a[i] - a[i - 1]) / (t[i] - t[i - 1]);
}

double SampleWindow::TableAcceleration(double t_s) const {
  if (size_ == 0) return 0.0;
  const double* t = times();
  const double* a = accels();
  if (!(t_s > t[0])) return a[0];
  if (t_s >= t[size_ - 1]) return a[size_ - 1];
  // The interval [t[i], t[i + 1]) holding t_s.
  const int i = static_cast<int>(std::upper_bound(t, t + size_, t_s) - t) - 1;
  const double h = t[i + 1] - t[i];
  const double s = (t_s - t[i]) / h;
  // The chord: kLinear, and kCubic's interval to the newest sample (not yet
  // fixed while open; the chord once closed).
  if (shape_ == Shape::kLinear || i + 2 >= size_) return a[i] + s * (a[i + 1] - a[i]);
  const double m0 = Slope(i) * h, m1 = Slope(i + 1) * h;
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * a[i] + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * a[i + 1] +
         (s3 - s2) * m1;
}

namespace {

// PEER NGA record (.AT2): four header lines, the third naming the quantity
// ("ACCELERATION TIME SERIES IN UNITS OF G"), the fourth NPTS and DT in one
// of two styles ("NPTS=  4316, DT=   .0100 SEC" or "4164    0.0100    NPTS,
// DT"), then NPTS accelerations in g, any number to a line (5 or 8 in the
// wild). Sample k is at k DT; values are converted to m/s^2 with g = 9.81.
std::string Upper(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

AccelerationRows ReadPeerAt2(const std::string& path, std::istream& in) {
  std::int64_t line_no = 0;
  auto fail = [&path, &line_no](const std::string& what) {
    throw std::runtime_error(path + ":" + std::to_string(line_no) + ": " + what);
  };
  std::string line;
  std::string header[4];
  for (int i = 0; i < 4; ++i) {
    if (!std::getline(in, line)) fail("a PEER .AT2 record has 4 header lines; the file ends after " + std::to_string(i));
    ++line_no;
    if (line_no == 1) common::StripByteOrderMark(line);
    header[i] = line;
  }
  const std::string quantity = Upper(header[2]);
  line_no = 3;
  if (quantity.find("VELOCITY") != std::string::npos || quantity.find("DISPLACEMENT") != std::string::npos) {
    fail("a PEER velocity or displacement record (" + common::Quote(common::Trim(header[2])) +
         "): --accel takes the acceleration record (.AT2)");
  }
  if (quantity.find("UNITS OF G") == std::string::npos) {
    fail("expected 'ACCELERATION TIME SERIES IN UNITS OF G', got " + common::Quote(common::Trim(header[2])));
  }
  // Line 4: the tokens between blanks, commas and '='.
  line_no = 4;
  std::vector<std::string> tokens;
  std::string token;
  for (char c : header[3] + " ") {
    if (c == ' ' || c == '\t' || c == ',' || c == '=' || c == '\r') {
      if (!token.empty()) tokens.push_back(Upper(token));
      token.clear();
    } else {
      token += c;
    }
  }
  double npts_value = std::numeric_limits<double>::quiet_NaN();
  double dt = std::numeric_limits<double>::quiet_NaN();
  double first = 0;
  if (!tokens.empty() && common::ParseDouble(tokens[0], first)) {
    // "4164    0.0100    NPTS, DT": the values first, then their names.
    if (tokens.size() >= 4 && tokens[2] == "NPTS" && tokens[3] == "DT") {
      npts_value = first;
      common::ParseDouble(tokens[1], dt);
    }
  } else {
    // "NPTS=  4316, DT=   .0100 SEC": each name, then its value.
    for (std::size_t i = 0; i + 1 < tokens.size(); ++i) {
      if (tokens[i] == "NPTS") common::ParseDouble(tokens[i + 1], npts_value);
      if (tokens[i] == "DT") common::ParseDouble(tokens[i + 1], dt);
    }
  }
  if (std::isnan(npts_value) || std::isnan(dt)) {
    fail("expected NPTS and DT ('NPTS=  4316, DT=   .0100 SEC' or '4164    0.0100    NPTS, DT'), got " +
         common::Quote(common::Trim(header[3])));
  }
  if (!(npts_value >= 2 && npts_value <= 1e9 && npts_value == std::floor(npts_value))) {
    fail("NPTS " + ExactText(npts_value) + " is not a count of at least 2 samples");
  }
  if (!(dt >= 1e-6 && dt <= 10)) fail("DT " + ExactText(dt) + " s is not in [1e-6, 10] s");
  const auto npts = static_cast<std::size_t>(npts_value);
  AccelerationRows rows;
  rows.time_s.reserve(npts);
  rows.accel_mps2.reserve(npts);
  rows.line.reserve(npts);
  std::vector<std::string_view> fields;
  while (std::getline(in, line)) {
    common::PollThreadCancel();
    ++line_no;
    std::string_view rest = common::Trim(line);
    while (!rest.empty()) {
      const std::size_t end = rest.find_first_of(" \t,");
      const std::string_view field = rest.substr(0, end);
      rest = end == std::string_view::npos ? std::string_view() : common::Trim(rest.substr(end + 1));
      if (field.empty()) continue;
      double g = 0;
      if (!common::ParseDouble(field, g) || !std::isfinite(g)) {
        fail("acceleration " + common::Quote(field) + " is not a finite number (g)");
      }
      if (rows.time_s.size() == npts) {
        fail("more values than NPTS " + std::to_string(npts) + " (line 4) says");
      }
      rows.time_s.push_back(static_cast<double>(rows.time_s.size()) * dt);
      rows.accel_mps2.push_back(g * common::kGravity);
      rows.line.push_back(line_no);
    }
  }
  if (rows.time_s.size() != npts) {
    line_no = 4;
    fail("NPTS " + std::to_string(npts) + " but the file has " + std::to_string(rows.time_s.size()) + " values");
  }
  return rows;
}

// A PEER record by its content: its fourth line names NPTS and DT.
bool LooksLikePeer(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  for (int i = 0; i < 4; ++i) {
    if (!std::getline(in, line)) return false;
  }
  const std::string upper = Upper(line);
  return upper.find("NPTS") != std::string::npos && upper.find("DT") != std::string::npos;
}

}  // namespace

AccelerationRows ReadAccelerationRows(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open for reading");
  if (common::HasExtension(path, ".vt2") || common::HasExtension(path, ".dt2")) {
    throw std::runtime_error(path + ": a PEER velocity (.VT2) or displacement (.DT2) record: --accel takes "
                             "the acceleration record (.AT2)");
  }
  if (common::HasExtension(path, ".at2") || LooksLikePeer(path)) return ReadPeerAt2(path, in);
  std::int64_t line_no = 0;
  auto fail = [&path, &line_no](const std::string& what) {
    throw std::runtime_error(path + ":" + std::to_string(line_no) + ": " + what);
  };
  AccelerationRows rows;
  std::string line;
  bool header = false;
  while (std::getline(in, line)) {
    common::PollThreadCancel();
    ++line_no;
    if (line_no == 1) common::StripByteOrderMark(line);
    const std::string_view text = common::Trim(line);
    if (text.empty() || text.front() == '#') continue;
    const auto comma = text.find(',');
    const bool two = comma != std::string_view::npos && text.find(',', comma + 1) == std::string_view::npos;
    const std::string_view fields[2] = {common::Trim(text.substr(0, two ? comma : 0)),
                                        common::Trim(two ? text.substr(comma + 1) : text)};
    if (!header) {
      if (!two || fields[0] != "time" || fields[1] != "accel") {
        fail("header is " + common::Quote(text) + ", expected 'time,accel' (s, m/s^2)");
      }
      header = true;
      continue;
    }
    if (!two) fail("expected 2 fields (time,accel), got " + common::Quote(text));
    const char* names[2] = {"time", "accel"};
    double v[2] = {0.0, 0.0};
    for (int k = 0; k < 2; ++k) {
      if (!common::ParseDouble(fields[k], v[k])) fail(std::string(names[k]) + " " + common::Quote(fields[k]) + " is not a number");
      if (!std::isfinite(v[k])) fail(std::string(names[k]) + " " + common::Quote(fields[k]) + " is not finite");
    }
    if (!rows.time_s.empty() && !(v[0] > rows.time_s.back())) {
      fail("time " + ExactText(v[0]) + " s is not after the previous sample " + ExactText(rows.time_s.back()) + " s");
    }
    rows.time_s.push_back(v[0]);
    rows.accel_mps2.push_back(v[1]);
    rows.line.push_back(line_no);
  }
  if (!header) throw std::runtime_error(path + ":1: empty file (expected header 'time,accel')");
  if (rows.time_s.size() < 2) fail("needs at least 2 samples, got " + std::to_string(rows.time_s.size()));
  return rows;
}

SampledAcceleration ReadAccelerationCsv(const std::string& path) {
  AccelerationRows rows = ReadAccelerationRows(path);
  return SampledAcceleration(std::move(rows.time_s), std::move(rows.accel_mps2));
}

}  // namespace rocklab::model
