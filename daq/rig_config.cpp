#include "daq/rig_config.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <toml++/toml.h>

#include "common/text.h"
#include "common/toml_reader.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {

using Reader = common::TomlReader;

constexpr double kMaxLengthM = 100.0;  // any length or coordinate in the rig, m
// The smallest size (width, height, lever, spacing, chamfer, polygon edge)
// of a laboratory rig, m: below it a value is a typo or a unit slip, and a
// degenerate block would fail far from the file.
constexpr double kMinSizeM = 1e-3;
constexpr int kMaxLeds = 64;           // LEDs a rigid fit may require

// `with_lag`: the section may set lag_s.
void ParseDifferentiator(Reader& r, const toml::table& root, const std::string& key,
                         DifferentiatorConfig& out, double rate_hz, bool with_lag) {
  // Without the table its defaults still meet the rate's bounds (checked,
  // with the root's line).
  const toml::table* t = r.Table(root, "", key, false);
  if (t != nullptr) {
    out.window_s = r.Double(*t, key, "window_s", out.window_s);
    out.order = r.Int(*t, key, "order", out.order, 2, kMaxDifferentiatorOrder);
  }
  const toml::table& where = t != nullptr ? *t : root;
  // The window must hold more samples than the order and at most
  // 2 kMaxHalfWindowSamples + 1 (the filter's cost per sample grows with it).
  const int min_half = std::max(1, out.order / 2);
  const double lo = 2.0 * min_half / rate_hz;
  const double hi = 2.0 * kMaxHalfWindowSamples / rate_hz;
  const double half = out.window_s * rate_hz / 2.0;
  if (!(half >= min_half - 0.5 && half < kMaxHalfWindowSamples + 0.5)) {
    std::ostringstream msg;
    msg << "must be in [" << lo << ", " << hi << "] s at sample_rate_hz " << rate_hz << " (" << 2 * min_half + 1
        << " to " << 2 * kMaxHalfWindowSamples + 1 << " samples for order " << out.order << "), got "
        << out.window_s << (t == nullptr ? " (the default)" : "");
    r.Check(false, where, key, "window_s", msg.str());
  }
  if (t != nullptr && with_lag) {
    out.lag_s = r.OptionalDouble(*t, key, "lag_s");
    // In samples: round(lag_s * rate) in [0, m] (compared in double first so
    // that a huge value cannot overflow the rounding).
    const int m = static_cast<int>(std::lround(half));
    if (out.lag_s && !(*out.lag_s >= 0 && *out.lag_s * rate_hz < m + 0.5)) {
      std::ostringstream msg;
      msg << "must be in [0, " << m / rate_hz << "] s (0: the window's causal end-point, " << m / rate_hz
          << ": its centre, " << m << " samples at sample_rate_hz " << rate_hz << "), got " << *out.lag_s;
      r.Check(false, *t, key, "lag_s", msg.str());
    }
  }
  if (t != nullptr) r.RejectUnknown(*t, key);
}

}  // namespace

const ChannelConfig* RigConfig::FindSensor(const std::string& sensor) const {
  for (const auto& c : channels) {
    if (c.sensor == sensor) return &c;
  }
  return nullptr;
}

int RigConfig::HalfWindow(const DifferentiatorConfig& d) const {
  return static_cast<int>(std::lround(d.window_s * sample_rate_hz / 2.0));
}

double RigConfig::contact_half_width_m(int k) const {
  if (k == 0 || bodies.size() < 2) return block.pivot_half_width_m();
  return 0.5 * std::min(bodies[static_cast<std::size_t>(k - 1)].width_m, bodies[static_cast<std::size_t>(k)].width_m);
}

double RigConfig::body_height_m(int k) const {
  return bodies.empty() ? block.height_m : bodies[static_cast<std::size_t>(k)].height_m;
}

int RigConfig::LagSamples(const DifferentiatorConfig& d) const {
  return d.lag_s ? static_cast<int>(std::lround(*d.lag_s * sample_rate_hz)) : HalfWindow(d);
}

namespace {

// [[body]]: an assembly's bodies bottom-up, each a named box; the rig's
// [block] is then the bottom body's box (and may not be given too).
void ParseBodies(Reader& r, const toml::table& root, RigConfig& rig) {
  const toml::array* bodies = r.Array(root, "", "body");
  if (bodies == nullptr) return;
  r.Check(!bodies->empty() && bodies->size() <= static_cast<std::size_t>(kMaxRigBodies), root, "", "body",
          "must list 1 to " + std::to_string(kMaxRigBodies) + " [[body]] tables, bottom-up");
  r.Check(root.get("block") == nullptr, root, "", "block",
          "must not be given beside [[body]] tables (the bottom body is the block)");
  for (const toml::node& node : *bodies) {
    const toml::table* t = node.as_table();
    if (t == nullptr) r.Fail(Reader::LineOf(node), "body", "must be an array of tables");
    RigBody body;
    body.line = Reader::LineOf(*t);
    body.name = r.String(*t, "body", "name", std::nullopt);
    bool unique = !body.name.empty();
    for (const RigBody& other : rig.bodies) unique = unique && other.name != body.name;
    r.Check(unique, *t, "body", "name", "must be non-empty and unique, got " + common::Quote(body.name));
    body.width_m = r.Bounded(*t, "body", "width_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
    body.height_m = r.Bounded(*t, "body", "height_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
    r.RejectUnknown(*t, "body");
    rig.bodies.push_back(std::move(body));
  }
  rig.block.width_m = rig.bodies.front().width_m;
  rig.block.height_m = rig.bodies.front().height_m;
}

// A sensor's `body` key: the index of the body it names. Required in a
// rig of several bodies; refused in a single-block one.
int BodyOf(Reader& r, const toml::table& t, const std::string& prefix, const RigConfig& rig) {
  if (rig.bodies.empty()) {
    r.Check(t.get("body") == nullptr, t, prefix, "body", "needs [[body]] tables naming the rig's bodies");
    return 0;
  }
  const std::optional<std::string> fallback =
      rig.bodies.size() == 1 ? std::optional<std::string>(rig.bodies.front().name) : std::nullopt;
  const std::string name = r.String(t, prefix, "body", fallback);
  for (std::size_t k = 0; k < rig.bodies.size(); ++k) {
    if (rig.bodies[k].name == name) return static_cast<int>(k);
  }
  std::string known;
  for (const RigBody& b : rig.bodies) known += " " + common::Quote(b.name);
  r.Check(false, t, prefix, "body", "names no [[body]]: " + common::Quote(name) + " (the bodies:" + known + ")");
  return 0;
}

// [block]: the size, the optional fitted parameters and polygon.
void ParseBlock(Reader& r, const toml::table& root, BlockConfig& block) {
  const toml::table& t = *r.Table(root, "", "block", true);
  block.width_m = r.Bounded(t, "block", "width_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
  block.height_m = r.Bounded(t, "block", "height_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
  block.chamfer_m = r.Double(t, "block", "chamfer_m", 0.0);
  {
    const double c = block.chamfer_m;
    const double half = 0.5 * std::min(block.width_m, block.height_m);
    std::ostringstream msg;
    msg << "must be 0 or in [" << kMinSizeM << ", " << half << ") m (min(width, height) / 2), got " << c;
    r.Check(c == 0 || (c >= kMinSizeM && c < half), t, "block", "chamfer_m", msg.str());
  }
  block.alpha = r.OptionalDouble(t, "block", "alpha");
  block.p = r.OptionalDouble(t, "block", "p");
  block.mu = r.OptionalDouble(t, "block", "mu");
  r.Check(!block.alpha || (*block.alpha > 0 && *block.alpha < common::kPi / 2), t, "block",
          "alpha", "must be in (0, pi/2) rad");
  r.Check(!block.p || *block.p > 0, t, "block", "p", "must be > 0 rad/s");
  r.Check(!block.mu || (*block.mu > 0 && *block.mu <= 1), t, "block", "mu",
          "must be in (0, 1]");
  // polygon = [[x, z], ...]: numbers here; the geometry (simple polygon,
  // centroid over the base) is checked where the model derives from it.
  if (const toml::array* poly = r.Array(t, "block", "polygon")) {
    block.polygon_line = Reader::LineOf(*poly);
    for (std::size_t i = 0; i < poly->size(); ++i) {
      const toml::node& vertex = *poly->get(i);
      const toml::array* xz = vertex.as_array();
      const auto x = xz != nullptr && xz->size() == 2 ? xz->get(0)->value<double>() : std::nullopt;
      const auto z = xz != nullptr && xz->size() == 2 ? xz->get(1)->value<double>() : std::nullopt;
      if (!x || !z || !(std::abs(*x) <= kMaxLengthM) || !(std::abs(*z) <= kMaxLengthM)) {
        r.Fail(Reader::LineOf(vertex), "block.polygon",
               "vertex " + std::to_string(i) + " must be a pair of finite numbers [x, z] within [-100, 100] m");
      }
      block.polygon_m.push_back({*x, *z});
    }
    r.Check(block.polygon_m.size() >= 3, t, "block", "polygon", "must list at least 3 [x, z] vertices");
    // Each edge, the closing one too, is a length of the rig (a repeated
    // vertex is an edge of 0 m).
    const auto& v = block.polygon_m;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::size_t j = (i + 1) % v.size();
      const double edge = std::hypot(v[j][0] - v[i][0], v[j][1] - v[i][1]);
      if (!(edge >= kMinSizeM && edge <= kMaxLengthM)) {
        std::ostringstream msg;
        msg << "edge from vertex " << i << " to vertex " << j << " is " << edge << " m long: each edge must be in ["
            << kMinSizeM << ", " << kMaxLengthM << "] m";
        r.Fail(block.polygon_line, "block.polygon", msg.str());
      }
    }
    r.Check(block.chamfer_m == 0.0, t, "block", "chamfer_m",
            "must be 0 with block.polygon (the polygon gives the section)");
  }
  r.RejectUnknown(t, "block");
}

// [mirror], [[camera]] and [out_of_plane]: the sensors, whose roles the
// channels may map (added to `roles`).
void ParseSensors(Reader& r, const toml::table& root, RigConfig& rig, std::set<std::string>& roles) {
  if (const toml::table* t = r.Table(root, "", "mirror", false)) {
    rig.mirror.present = true;
    rig.mirror.lever_m = r.Bounded(*t, "mirror", "lever_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
    rig.mirror.rest_s_m = r.Bounded(*t, "mirror", "rest_s_m", 0.0, -kMaxLengthM, kMaxLengthM, " m");
    rig.mirror.rest_n_m = r.Bounded(*t, "mirror", "rest_n_m", 0.0, -kMaxLengthM, kMaxLengthM, " m");
    rig.mirror.body = BodyOf(r, *t, "mirror", rig);
    r.RejectUnknown(*t, "mirror");
    roles.insert({"mirror.s", "mirror.n"});
  }

  if (const toml::array* cams = r.Array(root, "", "camera")) {
    for (const toml::node& node : *cams) {
      const toml::table* t = node.as_table();
      if (t == nullptr) r.Fail(Reader::LineOf(node), "camera", "must be an array of tables");
      CameraConfig cam;
      cam.name = r.String(*t, "camera", "name", std::nullopt);
      r.Check(!cam.name.empty() && cam.name.find('.') == std::string::npos, *t, "camera", "name",
              "must be non-empty without '.'");
      const toml::array* leds = r.Array(*t, "camera", "led");
      r.Check(leds != nullptr && !leds->empty(), *t, "camera", "led", "must list the camera's LEDs");
      for (const toml::node& led_node : *leds) {
        const toml::table* lt = led_node.as_table();
        if (lt == nullptr) r.Fail(Reader::LineOf(led_node), "camera.led", "must be a table");
        LedConfig led;
        led.name = r.String(*lt, "camera.led", "name", std::nullopt);
        r.Check(!led.name.empty() && led.name.find('.') == std::string::npos, *lt, "camera.led",
                "name", "must be non-empty without '.'");
        led.x_m = r.Bounded(*lt, "camera.led", "x_m", std::nullopt, -kMaxLengthM, kMaxLengthM, " m");
        led.z_m = r.Bounded(*lt, "camera.led", "z_m", std::nullopt, -kMaxLengthM, kMaxLengthM, " m");
        led.body = BodyOf(r, *lt, "camera.led", rig);
        const std::string role = cam.name + "." + led.name;
        r.Check(roles.count(role + ".x") == 0, *lt, "camera.led", "name",
                "repeats LED " + common::Quote(role));
        roles.insert({role + ".x", role + ".z"});
        r.RejectUnknown(*lt, "camera.led");
        cam.leds.push_back(led);
      }
      r.Get(*t, "camera", "video");  // [camera.video]: read by video/ (docs/video.md)
      r.RejectUnknown(*t, "camera");
      rig.cameras.push_back(std::move(cam));
    }
  }

  // [out_of_plane]: one pair, sensors oop.a and oop.b; [[out_of_plane]]
  // (a rig of [[body]] tables): a pair per body, sensors oop.BODY.a, .b.
  const toml::node* oop = root.get("out_of_plane");
  if (oop == nullptr) return;
  auto pair = [&](const toml::table& t, bool per_body) {
    OutOfPlaneConfig p;
    p.present = true;
    p.spacing_m = r.Bounded(t, "out_of_plane", "spacing_m", std::nullopt, kMinSizeM, kMaxLengthM, " m");
    p.body = BodyOf(r, t, "out_of_plane", rig);
    r.RejectUnknown(t, "out_of_plane");
    for (const OutOfPlaneConfig& other : rig.out_of_plane_pairs) {
      r.Check(other.body != p.body, t, "out_of_plane", "body",
              "repeats the pair of body " + common::Quote(rig.bodies[static_cast<std::size_t>(p.body)].name) +
                  " (one [[out_of_plane]] per body)");
    }
    if (per_body) p.role_prefix = "oop." + rig.bodies[static_cast<std::size_t>(p.body)].name;
    roles.insert({p.role_prefix + ".a", p.role_prefix + ".b"});
    rig.out_of_plane_pairs.push_back(p);
  };
  if (oop->is_array()) {
    const toml::array& pairs = *r.Array(root, "", "out_of_plane");
    if (rig.bodies.empty()) {
      r.Fail(Reader::LineOf(*oop), "out_of_plane",
             "as [[out_of_plane]] tables (a pair per body) needs [[body]] tables; a single block's pair is "
             "[out_of_plane]");
    }
    for (const toml::node& node : pairs) {
      const toml::table* t = node.as_table();
      if (t == nullptr) r.Fail(Reader::LineOf(node), "out_of_plane", "must be a table or an array of tables");
      pair(*t, true);
    }
  } else {
    pair(*r.Table(root, "", "out_of_plane", true), false);
  }
  if (!rig.out_of_plane_pairs.empty()) rig.out_of_plane = rig.out_of_plane_pairs.front();
}

// [posterior]: the priors of `rocklab fit --posterior`.
void ParsePosterior(Reader& r, const toml::table& root, PosteriorPriorConfig& c) {
  const toml::table* t = r.Table(root, "", "posterior", false);
  if (t == nullptr) return;
  c.line = Reader::LineOf(*t);
  c.alpha_band_m = r.OptionalDouble(*t, "posterior", "alpha_band_m");
  r.Check(!c.alpha_band_m || (*c.alpha_band_m > 0 && *c.alpha_band_m <= kMaxLengthM), *t, "posterior", "alpha_band_m",
          "must be in (0, 100] m");
  c.p_range = r.OptionalDouble(*t, "posterior", "p_range");
  r.Check(!c.p_range || (*c.p_range > 0 && *c.p_range < 1), *t, "posterior", "p_range", "must be in (0, 1)");
  c.mu_min = r.OptionalDouble(*t, "posterior", "mu_min");
  c.mu_max = r.OptionalDouble(*t, "posterior", "mu_max");
  const double mu_lo = c.mu_min.value_or(0.0), mu_hi = c.mu_max.value_or(1.0);
  r.Check(mu_lo >= 0 && mu_lo < 1, *t, "posterior", "mu_min", "must be in [0, 1)");
  r.Check(mu_hi > mu_lo && mu_hi <= 1, *t, "posterior", "mu_max", "must be in (mu_min, 1]");
  c.log10_l_min = r.OptionalDouble(*t, "posterior", "log10_l_min");
  c.log10_l_max = r.OptionalDouble(*t, "posterior", "log10_l_max");
  const double l_lo = c.log10_l_min.value_or(-14.0), l_hi = c.log10_l_max.value_or(-8.0);
  r.Check(l_lo >= -20 && l_lo < -2, *t, "posterior", "log10_l_min", "must be in [-20, -2)");
  r.Check(l_hi > l_lo && l_hi <= -2, *t, "posterior", "log10_l_max", "must be in (log10_l_min, -2]");
  c.t_offset_s = r.OptionalDouble(*t, "posterior", "t_offset_s");
  r.Check(!c.t_offset_s || (*c.t_offset_s > 0 && *c.t_offset_s <= 1), *t, "posterior", "t_offset_s",
          "must be in (0, 1] s");
  c.sigma_mu_max = r.OptionalDouble(*t, "posterior", "sigma_mu_max");
  r.Check(!c.sigma_mu_max || (*c.sigma_mu_max > 0 && *c.sigma_mu_max <= 0.5), *t, "posterior", "sigma_mu_max",
          "must be in (0, 0.5]");
  r.RejectUnknown(*t, "posterior");
}

// [checks]: the DAQ's tolerances.
void ParseChecks(Reader& r, const toml::table& root, CheckTolerances& c) {
  if (const toml::table* t = r.Table(root, "", "checks", false)) {
    const char* keys[] = {"sliding_m", "jump_m",      "twist_rad",      "out_of_plane_m",
                          "tilt_rad",  "disagree_rad", "led_sigma_m", "mirror_sigma_m",
                          "sigmas"};
    double* fields[] = {&c.sliding_m,   &c.jump_m,       &c.twist_rad,
                        &c.out_of_plane_m, &c.tilt_rad,  &c.disagree_rad,
                        &c.led_sigma_m, &c.mirror_sigma_m, &c.sigmas};
    // Upper bounds: far beyond any rig, short of what turns a check off by
    // overflow (m, rad, or standard deviations for sigmas).
    const double highs[] = {kMaxLengthM, kMaxLengthM, common::kPi, kMaxLengthM, common::kPi, common::kPi,
                            kMaxLengthM, kMaxLengthM, 1000.0};
    const char* units[] = {" m", " m", " rad", " m", " rad", " rad", " m", " m", ""};
    for (size_t i = 0; i < std::size(keys); ++i) {
      *fields[i] = r.Double(*t, "checks", keys[i], *fields[i]);
      std::ostringstream range;
      range << "must be in (0, " << highs[i] << "]" << units[i] << ", got " << *fields[i];
      r.Check(*fields[i] > 0 && *fields[i] <= highs[i], *t, "checks", keys[i], range.str());
    }
    c.min_leds = r.Int(*t, "checks", "min_leds", c.min_leds, 2, kMaxLeds);
    r.RejectUnknown(*t, "checks");
  }
}

// [[channel]]: each channel's sensor role, gain, offset and range; every
// role in `roles`, mapped once, camera LEDs and the out-of-plane pair whole.
void ParseChannels(Reader& r, const toml::table& root, const std::set<std::string>& roles, RigConfig& rig) {
  const toml::array* channels = r.Array(root, "", "channel");
  if (channels == nullptr || channels->empty()) {
    r.Fail(1, "channel", "is missing: the rig must map at least one channel");
  }
  std::set<std::string> names;
  std::set<std::string> used_roles;
  for (const toml::node& node : *channels) {
    const toml::table* t = node.as_table();
    if (t == nullptr) r.Fail(Reader::LineOf(node), "channel", "must be an array of tables");
    ChannelConfig ch;
    ch.line = Reader::LineOf(*t);
    ch.name = r.String(*t, "channel", "name", std::nullopt);
    r.Check(!ch.name.empty() && names.insert(ch.name).second, *t, "channel", "name",
            "must be non-empty and unique, got " + common::Quote(ch.name));
    ch.sensor = r.String(*t, "channel", "sensor", std::nullopt);
    r.Check(roles.count(ch.sensor) == 1, *t, "channel", "sensor",
            "names an unknown sensor " + common::Quote(ch.sensor) +
                " (declare its [mirror], [[camera]] LED or [out_of_plane] pair first)");
    r.Check(used_roles.insert(ch.sensor).second, *t, "channel", "sensor",
            "maps sensor " + common::Quote(ch.sensor) + " a second time");
    ch.gain = r.Double(*t, "channel", "gain", 1.0);
    r.Check(ch.gain != 0 && std::abs(ch.gain) >= 1e-300, *t, "channel", "gain",
            "must not be 0 (|gain| >= 1e-300)");
    ch.offset = r.Double(*t, "channel", "offset", 0.0);
    ch.unit = r.String(*t, "channel", "unit", std::string(ch.sensor == "table.acceleration" ? "m/s^2" : "m"));
    ch.raw_unit = r.String(*t, "channel", "raw_unit", std::string());
    ch.raw_min = r.Double(*t, "channel", "raw_min", ch.raw_min);
    ch.raw_max = r.Double(*t, "channel", "raw_max", ch.raw_max);
    r.Check(ch.raw_min < ch.raw_max, *t, "channel", "raw_max", "must be > raw_min");
    r.RejectUnknown(*t, "channel");
    rig.channels.push_back(std::move(ch));
  }
  // A camera LED needs both coordinates, the out-of-plane pair both LEDs.
  for (const std::string& role : used_roles) {
    const size_t dot = role.rfind('.');
    const std::string stem = role.substr(0, dot);
    const std::string axis = role.substr(dot + 1);
    std::string twin;
    if (axis == "x" || axis == "z") twin = stem + (axis == "x" ? ".z" : ".x");
    for (const OutOfPlaneConfig& p : rig.out_of_plane_pairs) {
      if (role == p.role_prefix + ".a") twin = p.role_prefix + ".b";
      if (role == p.role_prefix + ".b") twin = p.role_prefix + ".a";
    }
    if (!twin.empty() && used_roles.count(twin) == 0) {
      r.Fail(rig.FindSensor(role)->line, "channel.sensor",
             "maps " + common::Quote(role) + " but no channel maps " + common::Quote(twin));
    }
  }
  r.Check(!rig.mirror.present || used_roles.count("mirror.s") == 1, root, "", "mirror",
          "is declared but no channel maps sensor 'mirror.s'");
}

}  // namespace

RigConfig ParseRigConfig(const std::string& text, const std::string& path) {
  const toml::table root = common::ParseTomlText(text, path, "the rig file");
  Reader r(path, "a rig configuration");
  RigConfig rig;
  rig.path = path;
  rig.name = r.String(root, "", "name", std::nullopt);
  rig.calibration_id = r.String(root, "", "calibration_id", std::string());
  rig.sample_rate_hz = r.Bounded(root, "", "sample_rate_hz", std::nullopt, kMinSampleRateHz,
                                 kMaxSampleRateHz, " Hz");
  ParseBodies(r, root, rig);
  if (rig.bodies.empty()) ParseBlock(r, root, rig.block);
  // Sensor roles the rest of the file makes available.
  std::set<std::string> roles = {"table.displacement", "table.acceleration"};
  ParseSensors(r, root, rig, roles);
  ParseChecks(r, root, rig.checks);
  ParsePosterior(r, root, rig.posterior);
  ParseDifferentiator(r, root, "theta_dot", rig.theta_dot, rig.sample_rate_hz, false);
  ParseDifferentiator(r, root, "table", rig.table, rig.sample_rate_hz, true);
  ParseChannels(r, root, roles, rig);
  r.RejectUnknown(root, "");
  return rig;
}

std::vector<std::string> CheckFileUnits(const RigConfig& rig, const std::vector<std::string>& names,
                                        const std::vector<std::string>& units, const std::string& source_path) {
  using common::Quote;
  std::vector<std::string> warnings;
  for (const ChannelConfig& c : rig.channels) {
    for (std::size_t i = 0; i < names.size() && i < units.size(); ++i) {
      if (names[i] != c.name || units[i].empty()) continue;
      const std::string& file = units[i];
      std::ostringstream msg;
      msg << rig.path << ":" << c.line << ": channel " << Quote(c.name) << " (sensor " << Quote(c.sensor) << ")";
      if (!c.raw_unit.empty()) {
        if (file != c.raw_unit) {
          msg << " has raw_unit " << Quote(c.raw_unit) << " but " << source_path << " says its values are in "
              << Quote(file) << " (Y_Unit_Label): the calibration (gain " << c.gain << ", offset " << c.offset
              << " to " << c.unit << ") would be wrong; fix the rig file or the input";
          throw std::runtime_error(msg.str());
        }
      } else if (c.gain == 1.0 && c.offset == 0.0 && file != c.unit) {
        msg << " is in " << Quote(c.unit) << " with gain 1 and offset 0, so its raw values are taken as "
            << Quote(c.unit) << ", but " << source_path << " says they are in " << Quote(file)
            << " (Y_Unit_Label); set the channel's gain and offset, or raw_unit to have such a file refused";
        warnings.push_back(msg.str());
      }
    }
  }
  return warnings;
}

RigConfig LoadRigConfig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open the rig file");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseRigConfig(text.str(), path);
}

}  // namespace rocklab::daq
