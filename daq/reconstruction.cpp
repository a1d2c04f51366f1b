#include "daq/reconstruction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "common/text.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {
using common::kNaN;
}  // namespace

Rigid2d FitRigid2d(const double* model, const double* world, int n) {
  double mx = 0, mz = 0, wx = 0, wz = 0;
  for (int i = 0; i < n; ++i) {
    mx += model[2 * i];
    mz += model[2 * i + 1];
    wx += world[2 * i];
    wz += world[2 * i + 1];
  }
  mx /= n;
  mz /= n;
  wx /= n;
  wz /= n;
  // The rotation maximising sum q_i . R p_i of the centred point sets.
  double dot = 0, cross = 0;
  for (int i = 0; i < n; ++i) {
    const double px = model[2 * i] - mx, pz = model[2 * i + 1] - mz;
    const double qx = world[2 * i] - wx, qz = world[2 * i + 1] - wz;
    dot += px * qx + pz * qz;
    cross += px * qz - pz * qx;
  }
  Rigid2d fit;
  fit.phi = std::atan2(cross, dot);
  const double c = std::cos(fit.phi), s = std::sin(fit.phi);
  fit.cos_phi = c;
  fit.sin_phi = s;
  fit.tx = wx - (c * mx - s * mz);
  fit.tz = wz - (s * mx + c * mz);
  double sum_sq = 0;
  for (int i = 0; i < n; ++i) {
    const double ex = c * model[2 * i] - s * model[2 * i + 1] + fit.tx - world[2 * i];
    const double ez = s * model[2 * i] + c * model[2 * i + 1] + fit.tz - world[2 * i + 1];
    sum_sq += ex * ex + ez * ez;
  }
  fit.rms = std::sqrt(sum_sq / n);
  return fit;
}

double Reconstructor::Channel::Value(const Frame& frame) const {
  if (col < 0) return kNaN;
  const double raw = frame.values[col];
  if (!std::isfinite(raw) || !(raw > raw_min && raw < raw_max)) return kNaN;
  return gain * raw + offset;
}

Reconstructor::Channel Reconstructor::Bind(const RigConfig& rig, const std::string& sensor,
                                           const std::vector<std::string>& source_channels) {
  Channel ch;
  const ChannelConfig* config = rig.FindSensor(sensor);
  if (config == nullptr) return ch;
  for (size_t i = 0; i < source_channels.size(); ++i) {
    if (source_channels[i] == config->name) ch.col = static_cast<int>(i);
  }
  ch.gain = config->gain;
  ch.offset = config->offset;
  ch.raw_min = config->raw_min;
  ch.raw_max = config->raw_max;
  return ch;
}

Reconstructor::Reconstructor(const RigConfig& rig, const std::vector<std::string>& source_channels,
                             const std::string& source_path)
    : checks_(rig.checks),
      mirror_(rig.mirror),
      oop_(rig.out_of_plane),
      pivot_half_width_m_(rig.block.pivot_half_width_m()) {
  // Every channel the rig maps must be in the source; name them all at once.
  std::vector<const ChannelConfig*> missing;
  for (const auto& c : rig.channels) {
    bool found = false;
    for (const auto& name : source_channels) found = found || name == c.name;
    if (!found) missing.push_back(&c);
  }
  if (!missing.empty()) {
    std::ostringstream msg;
    // Names come from the rig file and from the input (a file's header, a
    // tcp:// peer, a log's RL_DAQ_CONFIG): quoted, every byte escaped.
    using common::Quote;
    msg << rig.path << ":" << missing[0]->line << ": channel " << Quote(missing[0]->name) << " (sensor "
        << Quote(missing[0]->sensor) << ") is not in " << source_path << " (its channels:";
    for (const auto& name : source_channels) msg << " " << Quote(name);
    msg << ")";
    if (missing.size() > 1) {
      msg << "; also missing:";
      for (size_t i = 1; i < missing.size(); ++i) msg << " " << Quote(missing[i]->name);
    }
    throw std::runtime_error(msg.str());
  }
  auto bind = [&](const std::string& sensor) {
    return Bind(rig, sensor, source_channels);
  };
  mirror_s_ = bind("mirror.s");
  mirror_n_ = bind("mirror.n");
  oop_a_ = bind("oop.a");
  oop_b_ = bind("oop.b");
  table_disp_ = bind("table.displacement");
  table_acc_ = bind("table.acceleration");
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) {
      const std::string role = cam.name + "." + led.name;
      if (rig.FindSensor(role + ".x") == nullptr) continue;  // LED not wired to any channel
      leds_.push_back(Led{led.x_m, led.z_m, bind(role + ".x"), bind(role + ".z")});
    }
  }
  model_xz_.resize(2 * leds_.size());
  world_xz_.resize(2 * leds_.size());
  // The per-frame constants: the mirror's angle noise, and the fit's noise
  // figures with every LED valid, for a pivot on either side.
  sigma_mirror_ = checks_.mirror_sigma_m / (2 * mirror_.lever_m);
  if (!leds_.empty()) {
    std::vector<double> all_xz;
    for (const Led& led : leds_) {
      all_xz.push_back(led.x_m);
      all_xz.push_back(led.z_m);
    }
    const int n = static_cast<int>(leds_.size());
    all_leds_noise_[0] = PredictNoise(all_xz.data(), n, -1.0 * pivot_half_width_m_);
    all_leds_noise_[1] = PredictNoise(all_xz.data(), n, 1.0 * pivot_half_width_m_);
  }
}

// Predicted noise for the LEDs used (isotropic sigma per coordinate):
// rotation sigma / sqrt(S), pivot sigma sqrt(1/n + d^2 / S), with S the
// spread of the LEDs about their centroid c and d = |pivot - c|.
Reconstructor::Noise Reconstructor::PredictNoise(const double* model_xz, int used, double bx) const {
  double cx = 0, cz = 0;
  for (int i = 0; i < used; ++i) {
    cx += model_xz[2 * i];
    cz += model_xz[2 * i + 1];
  }
  cx /= used;
  cz /= used;
  double spread = 0;
  for (int i = 0; i < used; ++i) {
    spread += std::pow(model_xz[2 * i] - cx, 2) + std::pow(model_xz[2 * i + 1] - cz, 2);
  }
  const double d2 = (bx - cx) * (bx - cx) + cz * cz;
  Noise noise;
  noise.sigma_theta = checks_.led_sigma_m / std::sqrt(spread);
  noise.sigma_pivot = checks_.led_sigma_m * std::sqrt(1.0 / used + d2 / spread);
  return noise;
}

void Reconstructor::Reconstruct(const Frame& frame, BlockState& out) {
  ++counts_.frames;
  out = BlockState{};
  out.seq = frame.seq;
  out.utime = frame.utime();
  out.time_s = frame.time_s;
  out.line = frame.line;
  out.theta_dot = kNaN;
  out.table_displacement = table_disp_.Value(frame);
  out.table_acceleration = table_acc_.Value(frame);

  // LED-mirror: the reflected beam turns by 2 theta.
  out.theta_mirror = out.tilt = kNaN;
  if (mirror_.present) {
    const double s = mirror_s_.Value(frame);
    if (std::isfinite(s)) {
      out.theta_mirror = 0.5 * std::atan((s - mirror_.rest_s_m) / mirror_.lever_m);
    } else {
      ++counts_.invalid_mirror_samples;
      out.flags |= kFlagNoMirror;
    }
    const double n = mirror_n_.Value(frame);
    if (std::isfinite(n)) out.tilt = 0.5 * std::atan((n - mirror_.rest_n_m) / mirror_.lever_m);
  }

  // Lateral LEDs: rigid fit of the valid ones.
  out.theta_camera = out.sliding = out.jump = out.fit_rms_m = kNaN;
  out.sigma_theta_camera = out.sigma_pivot_m = kNaN;
  int used = 0;
  for (const Led& led : leds_) {
    const double x = led.x.Value(frame);
    const double z = led.z.Value(frame);
    if (!std::isfinite(x) || !std::isfinite(z)) {
      ++out.leds_invalid;
      continue;
    }
    model_xz_[2 * used] = led.x_m;
    model_xz_[2 * used + 1] = led.z_m;
    world_xz_[2 * used] = x;
    world_xz_[2 * used + 1] = z;
    ++used;
  }
  counts_.invalid_led_samples += out.leds_invalid;
  out.leds_used = used;
  if (!leds_.empty()) {
    if (used >= checks_.min_leds) {
      const Rigid2d fit = FitRigid2d(model_xz_.data(), world_xz_.data(), used);
      // theta > 0 tips the block towards +x: a clockwise turn in (x, z).
      out.theta_camera = -fit.phi;
      out.fit_rms_m = fit.rms;
      const double side = out.theta_camera >= 0 ? 1.0 : -1.0;
      const double bx = side * pivot_half_width_m_;  // pivot in the block frame (z = 0)
      const double pivot_x = fit.cos_phi * bx + fit.tx;
      const double pivot_z = fit.sin_phi * bx + fit.tz;
      // No table channel: a fixed base. An invalid table sample: sliding unknown.
      const double table = has_table_displacement() ? out.table_displacement : 0.0;
      // With every LED valid (the usual frame) the noise figures are the
      // constructor's, computed by the same function: the same bits.
      const Noise noise = used == static_cast<int>(leds_.size()) ? all_leds_noise_[side > 0 ? 1 : 0]
                                                                 : PredictNoise(model_xz_.data(), used, bx);
      out.sigma_theta_camera = noise.sigma_theta;
      out.sigma_pivot_m = noise.sigma_pivot;
      // A pivot too noisy for a tolerance is reported unmeasured, not guessed.
      const double reach = checks_.sigmas * out.sigma_pivot_m;
      out.sliding = reach <= checks_.sliding_m ? pivot_x - bx - table : kNaN;
      out.jump = reach <= checks_.jump_m ? pivot_z : kNaN;
      if (reach > checks_.sliding_m || reach > checks_.jump_m) ++counts_.imprecise_pivot_frames;
    } else {
      ++counts_.no_camera_frames;
      out.flags |= kFlagNoCamera;
    }
  }

  // Out-of-plane LED pair.
  out.twist = out.out_of_plane = kNaN;
  if (oop_.present) {
    const double ya = oop_a_.Value(frame);
    const double yb = oop_b_.Value(frame);
    if (std::isfinite(ya) && std::isfinite(yb)) {
      // A yaw psi moves LED b relative to LED a by spacing * sin(psi) out of plane.
      out.twist = std::asin(std::clamp((yb - ya) / oop_.spacing_m, -1.0, 1.0));
      out.out_of_plane = 0.5 * (ya + yb);
    }
  }

  // Best theta: the mirror when valid (finer: the optical lever doubles the
  // angle), else the cameras.
  out.theta = std::isfinite(out.theta_mirror) ? out.theta_mirror : out.theta_camera;
  if (!std::isfinite(out.theta)) ++counts_.no_theta_frames;

  // "The channels other than theta must be either functions of theta or zero."
  // A quantity that is NaN (unmeasured) is not checked.
  auto check = [&out](int32_t flag, bool measured, bool exceeded) {
    if (!measured) return;
    out.checked |= flag;
    if (exceeded) out.flags |= flag;
  };
  check(kFlagSliding, std::isfinite(out.sliding), std::abs(out.sliding) > checks_.sliding_m);
  check(kFlagJump, std::isfinite(out.jump), std::abs(out.jump) > checks_.jump_m);
  check(kFlagTwist, std::isfinite(out.twist), std::abs(out.twist) > checks_.twist_rad);
  check(kFlagOutOfPlane, std::isfinite(out.out_of_plane) || std::isfinite(out.tilt),
        std::abs(out.out_of_plane) > checks_.out_of_plane_m || std::abs(out.tilt) > checks_.tilt_rad);
  // Disagreement is judged only where the two angles are precise enough.
  check(kFlagDisagree,
        std::isfinite(out.theta_mirror) && std::isfinite(out.theta_camera) &&
            checks_.sigmas * std::hypot(sigma_mirror_, out.sigma_theta_camera) <= checks_.disagree_rad,
        std::abs(out.theta_mirror - out.theta_camera) > checks_.disagree_rad);
}

}  // namespace rocklab::daq
