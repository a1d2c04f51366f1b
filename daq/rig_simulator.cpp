#include "daq/rig_simulator.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "common/text.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {
using common::kNaN;
}  // namespace

SimulatorNoise SimulatorNoise::Scaled(double factor) const {
  SimulatorNoise n = *this;
  n.led_m *= factor;
  n.mirror_m *= factor;
  n.oop_m *= factor;
  n.table_m *= factor;
  n.accel_mps2 *= factor;
  return n;
}

SimulatorNoise SimulatorNoise::Typical() {
  SimulatorNoise n;
  n.led_m = 2e-4;
  n.mirror_m = 1e-4;
  n.oop_m = 1e-4;
  n.table_m = 2e-5;
  n.accel_mps2 = 0.05;
  n.occlusion = 0.01;
  n.drop = 0.001;
  return n;
}

RigSimulator::RigSimulator(const RigConfig& rig, const SimulatorNoise& noise, uint64_t seed)
    : rig_(rig), noise_(noise), rng_(seed) {
  for (double sd : {noise.led_m, noise.mirror_m, noise.oop_m, noise.table_m, noise.accel_mps2}) {
    if (!(sd >= 0)) throw std::invalid_argument("simulator: noise standard deviations must be >= 0");
  }
  for (double p : {noise.occlusion, noise.drop}) {
    if (!(p >= 0 && p < 1)) throw std::invalid_argument("simulator: probabilities must be in [0, 1)");
  }
  // Per channel: its noise and the LED it belongs to (x and z share one
  // occlusion draw).
  std::vector<std::string> leds;
  for (const auto& ch : rig_.channels) {
    names_.push_back(ch.name);
    const std::string& s = ch.sensor;
    int led = -1;
    double sd = noise_.led_m;
    if (s == "table.displacement") sd = noise_.table_m;
    else if (s == "table.acceleration") sd = noise_.accel_mps2;
    else if (s.rfind("mirror.", 0) == 0) sd = noise_.mirror_m;
    else if (s.rfind("oop.", 0) == 0) sd = noise_.oop_m;
    else {
      const std::string role = s.substr(0, s.rfind('.'));
      for (size_t k = 0; k < leds.size(); ++k) {
        if (leds[k] == role) led = static_cast<int>(k);
      }
      if (led < 0) {
        led = static_cast<int>(leds.size());
        leds.push_back(role);
      }
    }
    sd_.push_back(sd);
    led_of_.push_back(led);
  }
  led_hidden_.assign(leds.size(), 0);
}

double RigSimulator::Physical(const std::string& sensor, const TrueMotion& m) const {
  if (sensor == "table.displacement") return m.table_displacement;
  if (sensor == "table.acceleration") return m.table_acceleration;
  // A multi-body rig's mirror turns with its body.
  const double mirror_theta = rig_.multi_body() ? m.body_theta[static_cast<std::size_t>(rig_.mirror.body)] : m.theta;
  if (sensor == "mirror.s") return rig_.mirror.rest_s_m + rig_.mirror.lever_m * std::tan(2 * mirror_theta);
  if (sensor == "mirror.n") return rig_.mirror.rest_n_m + rig_.mirror.lever_m * std::tan(2 * m.tilt_rad);
  for (const OutOfPlaneConfig& pair : rig_.out_of_plane_pairs) {
    const bool a = sensor == pair.role_prefix + ".a";
    if (!a && sensor != pair.role_prefix + ".b") continue;
    // LED a at x = -spacing/2, LED b at +spacing/2 (block frame); a yaw psi
    // moves each by x sin(psi) out of plane. A multi-body rig: the twisting
    // body carries the ones above it.
    const double twist = !rig_.multi_body() || pair.body >= m.twist_body ? m.twist_rad : 0.0;
    const double half = 0.5 * pair.spacing_m * std::sin(twist);
    return m.out_of_plane_m + (a ? -half : half);
  }
  // <camera>.<led>.x|z: the block turns clockwise by theta about its pivot
  // corner, which sits at the table's position plus the slip and lift.
  const size_t dot = sensor.rfind('.');
  const std::string led_role = sensor.substr(0, dot);
  for (const auto& cam : rig_.cameras) {
    for (const auto& led : cam.leds) {
      if (cam.name + "." + led.name != led_role) continue;
      if (rig_.multi_body()) {
        double wx = 0, wz = 0;
        BodyPoint(m, led.body, led.x_m, led.z_m, wx, wz);
        return sensor[dot + 1] == 'x' ? wx : wz;
      }
      const double b = rig_.block.pivot_half_width_m();
      const double bx = m.theta >= 0 ? b : -b;
      const double qx = led.x_m - bx, qz = led.z_m;
      const double c = std::cos(m.theta), s = std::sin(m.theta);
      const double px = bx + m.table_displacement + m.slip_m;
      const double pz = m.lift_m;
      if (sensor[dot + 1] == 'x') return px + c * qx + s * qz;
      return pz - s * qx + c * qz;
    }
  }
  throw std::invalid_argument("simulator: unknown sensor '" + sensor + "'");
}

void RigSimulator::BodyPoint(const TrueMotion& m, int k, double x_m, double z_m, double& wx_m,
                             double& wz_m) const {
  // Up the stack: body j's pivot P_j (rig frame) and its corner bx_j (its
  // frame); a point (x, z) of body j is P_j + R(theta_j) (x - bx_j, z),
  // R turning clockwise by theta (theta > 0 tips towards +x).
  double px = 0, pz = 0, bx = 0, c = 1, s = 0, below = 0;
  for (int j = 0; j <= k; ++j) {
    const double theta = m.body_theta[static_cast<std::size_t>(j)];
    const double half = rig_.contact_half_width_m(j);
    const double corner = theta - below >= 0 ? half : -half;
    const double slip = j == m.slip_body ? m.slip_m : 0.0;
    const double lift = j == m.slip_body ? m.lift_m : 0.0;
    if (j == 0) {
      px = corner + m.table_displacement + slip;
      pz = lift;
    } else {
      // The same corner on the top face of body j - 1.
      const double qx = corner + slip - bx, qz = rig_.body_height_m(j - 1) + lift;
      const double nx = px + c * qx + s * qz;
      pz = pz - s * qx + c * qz;
      px = nx;
    }
    bx = corner;
    c = std::cos(theta);
    s = std::sin(theta);
    below = theta;
  }
  const double qx = x_m - bx, qz = z_m;
  wx_m = px + c * qx + s * qz;
  wz_m = pz - s * qx + c * qz;
}

bool RigSimulator::Raw(const TrueMotion& motion, std::vector<double>& raw) {
  // Draw in a fixed order whatever the outcome, so one seed gives one stream.
  const bool dropped = uniform_(rng_) < noise_.drop;
  for (auto& h : led_hidden_) h = uniform_(rng_) < noise_.occlusion;
  raw.resize(rig_.channels.size());
  for (size_t i = 0; i < rig_.channels.size(); ++i) {
    const ChannelConfig& ch = rig_.channels[i];
    const double physical = Physical(ch.sensor, motion) + sd_[i] * normal_(rng_);
    const bool hidden = led_of_[i] >= 0 && led_hidden_[led_of_[i]];
    raw[i] = hidden ? kNaN : (physical - ch.offset) / ch.gain;
  }
  return !dropped;
}

RawFileWriter::Format RawFileWriter::FormatOf(const std::string& path) {
  return common::HasExtension(path, ".lvm") ? Format::kLvm : Format::kCsv;
}

RawFileWriter::RawFileWriter(const std::string& path, Format format,
                             std::vector<std::string> channel_names, double sample_rate_hz,
                             bool decimal_comma)
    : out_(path, std::ios::binary),
      path_(path),
      format_(format),
      names_(std::move(channel_names)),
      rate_hz_(sample_rate_hz),
      decimal_comma_(format == Format::kLvm && decimal_comma),
      sep_(format == Format::kLvm ? '\t' : ',') {
  if (!out_) throw std::runtime_error(path + ": cannot create the raw file");
  if (format_ == Format::kCsv) {
    out_ << "time";
    for (const auto& n : names_) out_ << ',' << n;
    out_ << '\n';
  } else {
    out_ << "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\n"
         << "Decimal_Separator\t" << (decimal_comma_ ? ',' : '.') << "\n"
         << "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\nOperator\trocklab\n"
         << "***End_of_Header***\t\n";
  }
}

void RawFileWriter::Number(double v) {
  char buf[40];
  if (std::isnan(v)) {
    out_ << "NaN";
    return;
  }
  // 10 significant digits: finer than any sensor's resolution.
  std::snprintf(buf, sizeof buf, "%.10g", v);
  if (decimal_comma_) {
    for (char* c = buf; *c != '\0'; ++c) {
      if (*c == '.') *c = ',';
    }
  }
  out_ << buf;
}

void RawFileWriter::StartSegment(double t0_s, int64_t samples) {
  if (format_ != Format::kLvm) return;
  const size_t n = names_.size();
  out_ << "\t\nChannels\t" << n << "\t\nSamples";
  for (size_t i = 0; i < n; ++i) out_ << '\t' << samples;
  out_ << "\t\nX_Dimension";
  for (size_t i = 0; i < n; ++i) out_ << "\tTime";
  out_ << "\t\nX0";
  for (size_t i = 0; i < n; ++i) {
    out_ << '\t';
    Number(t0_s);
  }
  out_ << "\t\nDelta_X";
  for (size_t i = 0; i < n; ++i) {
    out_ << '\t';
    Number(1.0 / rate_hz_);
  }
  out_ << "\t\n***End_of_Header***\t\nX_Value";
  for (const auto& name : names_) out_ << '\t' << name;
  out_ << "\tComment\n";
}

void RawFileWriter::Write(double time_s, const std::vector<double>& values) {
  Number(time_s);
  for (double v : values) {
    out_ << sep_;
    Number(v);
  }
  out_ << '\n';
}

void RawFileWriter::Close() {
  out_.flush();
  if (!out_) throw std::runtime_error(path_ + ": write error");
  out_.close();
}

}  // namespace rocklab::daq
