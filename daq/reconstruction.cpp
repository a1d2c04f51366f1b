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

// "The channels other than theta must be either functions of theta or
// zero": the checks of one state (the single block's or a body's). A
// quantity that is NaN (unmeasured) is not checked.
template <class S>
void RockingChecks(S& out, const CheckTolerances& checks, double sigma_mirror) {
  auto check = [&out](int32_t flag, bool measured, bool exceeded) {
    if (!measured) return;
    out.checked |= flag;
    if (exceeded) out.flags |= flag;
  };
  check(kFlagSliding, std::isfinite(out.sliding), std::abs(out.sliding) > checks.sliding_m);
  check(kFlagJump, std::isfinite(out.jump), std::abs(out.jump) > checks.jump_m);
  check(kFlagTwist, std::isfinite(out.twist), std::abs(out.twist) > checks.twist_rad);
  check(kFlagOutOfPlane, std::isfinite(out.out_of_plane) || std::isfinite(out.tilt),
        std::abs(out.out_of_plane) > checks.out_of_plane_m || std::abs(out.tilt) > checks.tilt_rad);
  // Disagreement is judged only where the two angles are precise enough.
  check(kFlagDisagree,
        std::isfinite(out.theta_mirror) && std::isfinite(out.theta_camera) &&
            checks.sigmas * std::hypot(sigma_mirror, out.sigma_theta_camera) <= checks.disagree_rad,
        std::abs(out.theta_mirror - out.theta_camera) > checks.disagree_rad);
}
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
  for (const OutOfPlaneConfig& p : rig.out_of_plane_pairs) {
    oop_.push_back({bind(p.role_prefix + ".a"), bind(p.role_prefix + ".b"), p.spacing_m, p.body});
  }
  table_disp_ = bind("table.displacement");
  table_acc_ = bind("table.acceleration");
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) {
      const std::string role = cam.name + "." + led.name;
      if (rig.FindSensor(role + ".x") == nullptr) continue;  // LED not wired to any channel
      leds_.push_back(Led{led.x_m, led.z_m, bind(role + ".x"), bind(role + ".z"), led.body});
    }
  }
  // Each body's LEDs together, in rig order (all of them body 0's in a single-block rig).
  std::stable_sort(leds_.begin(), leds_.end(), [](const Led& a, const Led& b) { return a.body < b.body; });
  if (rig.multi_body()) {
    body_count_ = rig.body_count();
    mirror_body_ = rig.mirror.body;
    for (int k = 0; k < body_count_; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      contact_half_width_m_[kk] = rig.contact_half_width_m(k);
      height_m_[kk] = rig.body_height_m(k);
      int begin = 0;
      while (begin < static_cast<int>(leds_.size()) && leds_[static_cast<std::size_t>(begin)].body < k) ++begin;
      body_begin_[kk] = begin;
    }
    body_begin_[static_cast<std::size_t>(body_count_)] = static_cast<int>(leds_.size());
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
    all_leds_noise_[0] = PredictNoise(all_xz.data(), n, -1.0 * pivot_half_width_m_, 0.0);
    all_leds_noise_[1] = PredictNoise(all_xz.data(), n, 1.0 * pivot_half_width_m_, 0.0);
  }
}

// Predicted noise for the LEDs used (isotropic sigma per coordinate):
// rotation sigma / sqrt(S), a point's sigma sqrt(1/n + d^2 / S), with S the
// spread of the LEDs about their centroid c and d = |point - c|.
Reconstructor::Noise Reconstructor::PredictNoise(const double* model_xz, int used, double px, double pz) const {
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
  const double d2 = (px - cx) * (px - cx) + (pz - cz) * (pz - cz);
  Noise noise;
  noise.sigma_theta = checks_.led_sigma_m / std::sqrt(spread);
  noise.sigma_pivot = checks_.led_sigma_m * std::sqrt(1.0 / used + d2 / spread);
  return noise;
}

// LED-mirror: the reflected beam turns by 2 theta. Leaves what it cannot
// measure as it was (NaN).
void Reconstructor::ReadMirror(const Frame& frame, double& theta_mirror, double& tilt, int32_t& flags) {
  const double s = mirror_s_.Value(frame);
  if (std::isfinite(s)) {
    theta_mirror = 0.5 * std::atan((s - mirror_.rest_s_m) / mirror_.lever_m);
  } else {
    ++counts_.invalid_mirror_samples;
    flags |= kFlagNoMirror;
  }
  const double n = mirror_n_.Value(frame);
  if (std::isfinite(n)) tilt = 0.5 * std::atan((n - mirror_.rest_n_m) / mirror_.lever_m);
}

void Reconstructor::ReadOutOfPlane(const Frame& frame, const OutOfPlanePair& pair, double& twist,
                                   double& out_of_plane) {
  const double ya = pair.a.Value(frame);
  const double yb = pair.b.Value(frame);
  if (std::isfinite(ya) && std::isfinite(yb)) {
    // A yaw psi moves LED b relative to LED a by spacing * sin(psi) out of plane.
    twist = std::asin(std::clamp((yb - ya) / pair.spacing_m, -1.0, 1.0));
    out_of_plane = 0.5 * (ya + yb);
  }
}

void Reconstructor::Reconstruct(const Frame& frame, BlockState& out) {
  ++counts_.frames;
  std::vector<BodyState> bodies = std::move(out.bodies);  // kept: no allocation per frame
  out = BlockState{};
  out.bodies = std::move(bodies);
  out.seq = frame.seq;
  out.utime = frame.utime();
  out.time_s = frame.time_s;
  out.line = frame.line;
  out.theta_dot = kNaN;
  out.table_displacement = table_disp_.Value(frame);
  out.table_acceleration = table_acc_.Value(frame);
  if (body_count_ > 0) {
    ReconstructBodies(frame, out);
    return;
  }

  // LED-mirror: the reflected beam turns by 2 theta.
  out.theta_mirror = out.tilt = kNaN;
  if (mirror_.present) ReadMirror(frame, out.theta_mirror, out.tilt, out.flags);

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
                                                                 : PredictNoise(model_xz_.data(), used, bx, 0.0);
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
  if (!oop_.empty()) ReadOutOfPlane(frame, oop_.front(), out.twist, out.out_of_plane);

  // Best theta: the mirror when valid (finer: the optical lever doubles the
  // angle), else the cameras.
  out.theta = std::isfinite(out.theta_mirror) ? out.theta_mirror : out.theta_camera;
  if (!std::isfinite(out.theta)) ++counts_.no_theta_frames;

  RockingChecks(out, checks_, sigma_mirror_);
}

void Reconstructor::ReconstructBodies(const Frame& frame, BlockState& out) {
  out.body_count = body_count_;
  out.bodies.assign(static_cast<std::size_t>(body_count_), BodyState{});
  const double table = has_table_displacement() ? out.table_displacement : 0.0;
  // Each body's rigid fit of its own valid LEDs, packed at its LEDs' offset.
  struct BodyFit {
    bool ok{false};
    Rigid2d fit;
    int begin{};
    int used{};
  };
  std::array<BodyFit, kMaxRigBodies> fits{};
  // The counts are of frames: one where any body lacks what they count.
  bool no_camera = false, imprecise = false, no_theta = false;
  for (int k = 0; k < body_count_; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    BodyState& b = out.bodies[kk];
    b.theta_dot = b.theta_mirror = b.theta_camera = b.sliding = b.jump = kNaN;
    b.twist = b.out_of_plane = b.tilt = b.sigma_theta_camera = b.sigma_slide_m = kNaN;
    BodyFit& f = fits[kk];
    f.begin = body_begin_[kk];
    for (int i = body_begin_[kk]; i < body_begin_[kk + 1]; ++i) {
      const Led& led = leds_[static_cast<std::size_t>(i)];
      const double x = led.x.Value(frame);
      const double z = led.z.Value(frame);
      if (!std::isfinite(x) || !std::isfinite(z)) {
        ++out.leds_invalid;
        continue;
      }
      const auto at = static_cast<std::size_t>(2 * (f.begin + f.used));
      model_xz_[at] = led.x_m;
      model_xz_[at + 1] = led.z_m;
      world_xz_[at] = x;
      world_xz_[at + 1] = z;
      ++f.used;
    }
    b.leds_used = f.used;
    if (body_begin_[kk + 1] == body_begin_[kk]) continue;  // a body without LEDs
    if (f.used >= checks_.min_leds) {
      f.fit = FitRigid2d(&model_xz_[static_cast<std::size_t>(2 * f.begin)],
                         &world_xz_[static_cast<std::size_t>(2 * f.begin)], f.used);
      f.ok = true;
      b.theta_camera = -f.fit.phi;
      b.sigma_theta_camera = PredictNoise(&model_xz_[static_cast<std::size_t>(2 * f.begin)], f.used, 0.0, 0.0).sigma_theta;
    } else {
      no_camera = true;
      b.flags |= kFlagNoCamera;
    }
  }
  counts_.invalid_led_samples += out.leds_invalid;
  counts_.no_camera_frames += no_camera ? 1 : 0;

  // The pivot of each body on the one below (or the table): its corner on
  // the side its relative angle leans to, mapped by its fit, against the
  // same point of the face below (the table's, or the lower body's top
  // face at z = its height, mapped by that body's fit), in the lower
  // body's frame. Pure rocking keeps the two together.
  for (int k = 0; k < body_count_; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    BodyState& b = out.bodies[kk];
    const BodyFit& f = fits[kk];
    if (!f.ok || (k > 0 && !fits[kk - 1].ok)) continue;
    const double below = k > 0 ? -fits[kk - 1].fit.phi : 0.0;
    const double side = b.theta_camera - below >= 0 ? 1.0 : -1.0;
    const double bx = side * contact_half_width_m_[kk];
    const double px = f.fit.cos_phi * bx + f.fit.tx;
    const double pz = f.fit.sin_phi * bx + f.fit.tz;
    double sliding = 0, jump = 0;
    double sigma = PredictNoise(&model_xz_[static_cast<std::size_t>(2 * f.begin)], f.used, bx, 0.0).sigma_pivot;
    if (k == 0) {
      sliding = px - bx - table;
      jump = pz;
    } else {
      const BodyFit& g = fits[kk - 1];
      const double h = height_m_[kk - 1];
      const double qx = g.fit.cos_phi * bx - g.fit.sin_phi * h + g.fit.tx;
      const double qz = g.fit.sin_phi * bx + g.fit.cos_phi * h + g.fit.tz;
      // P - Q turned into the lower body's frame (R(phi)^T).
      sliding = g.fit.cos_phi * (px - qx) + g.fit.sin_phi * (pz - qz);
      jump = -g.fit.sin_phi * (px - qx) + g.fit.cos_phi * (pz - qz);
      sigma = std::hypot(sigma, PredictNoise(&model_xz_[static_cast<std::size_t>(2 * g.begin)], g.used, bx, h).sigma_pivot);
    }
    b.sigma_slide_m = sigma;
    const double reach = checks_.sigmas * sigma;
    b.sliding = reach <= checks_.sliding_m ? sliding : kNaN;
    b.jump = reach <= checks_.jump_m ? jump : kNaN;
    if (reach > checks_.sliding_m || reach > checks_.jump_m) imprecise = true;
  }

  counts_.imprecise_pivot_frames += imprecise ? 1 : 0;

  // The mirror and the out-of-plane pairs, on the bodies the rig names
  // (each body's twist and out-of-plane motion from its own pair).
  if (mirror_.present) {
    BodyState& b = out.bodies[static_cast<std::size_t>(mirror_body_)];
    ReadMirror(frame, b.theta_mirror, b.tilt, b.flags);
  }
  for (const OutOfPlanePair& pair : oop_) {
    BodyState& b = out.bodies[static_cast<std::size_t>(pair.body)];
    ReadOutOfPlane(frame, pair, b.twist, b.out_of_plane);
  }

  for (int k = 0; k < body_count_; ++k) {
    BodyState& b = out.bodies[static_cast<std::size_t>(k)];
    b.theta = std::isfinite(b.theta_mirror) ? b.theta_mirror : b.theta_camera;
    if (!std::isfinite(b.theta)) no_theta = true;
    RockingChecks(b, checks_, sigma_mirror_);
  }
  counts_.no_theta_frames += no_theta ? 1 : 0;
  // RL_THETA's single block: the bottom body.
  const BodyState& bottom = out.bodies[0];
  out.theta = bottom.theta;
  out.theta_mirror = bottom.theta_mirror;
  out.theta_camera = bottom.theta_camera;
  out.sliding = bottom.sliding;
  out.jump = bottom.jump;
  out.twist = bottom.twist;
  out.out_of_plane = bottom.out_of_plane;
  out.tilt = bottom.tilt;
  out.fit_rms_m = fits[0].ok ? fits[0].fit.rms : kNaN;
  out.sigma_theta_camera = bottom.sigma_theta_camera;
  out.sigma_pivot_m = bottom.sigma_slide_m;
  out.leds_used = bottom.leds_used;
  out.flags = bottom.flags;
  out.checked = bottom.checked;
}

}  // namespace rocklab::daq
