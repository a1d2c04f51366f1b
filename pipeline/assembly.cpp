// An assembly file read with common::TomlReader (file, line and key in every
// error; unknown keys refused) and run by the single-block model or by the
// stack model (pipeline/assembly.h).
#include "pipeline/assembly.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "common/toml_reader.h"
#include "common/units.h"
#include "model/model_registry.h"
#include "pipeline/option_error.h"

namespace rocklab::pipeline {
namespace {

using AssemblyToml = common::TomlReader;

// Sizes as the rig file bounds them (daq/rig_config.cpp): below 1 mm a value
// is a typo or a unit slip, above 100 m not a laboratory's.
constexpr double kAssemblyMinSizeM = 1e-3;
constexpr double kAssemblyMaxSizeM = 100.0;
constexpr double kAssemblyMaxMassKg = 1e9;
// Rows of a run held in memory (a stack's run is kept whole): 1e7 rows of 8
// bodies is ~1.3 GB.
constexpr double kAssemblyMaxRows = 1e7;

std::string AssemblyFolderOf(const std::string& name, const std::string& value) {
  const std::filesystem::path p(value);
  if (value.empty() || p.is_absolute()) return value;
  return (std::filesystem::path(name).parent_path() / p).lexically_normal().string();
}

double AssemblyMass(AssemblyToml& r, const toml::table& t, const std::string& prefix, double width_m,
                    double height_m) {
  const bool by_mass = t.contains("mass_kg");
  const bool by_density = t.contains("depth_m") || t.contains("density_kg_m3");
  if (by_mass && by_density) {
    r.Check(false, t, prefix, "mass_kg", "is given with depth_m/density_kg_m3: give one of them");
  }
  if (by_mass) return r.Bounded(t, prefix, "mass_kg", std::nullopt, 1e-9, kAssemblyMaxMassKg, " kg");
  if (!by_density) r.Check(false, t, prefix, "mass_kg", "is missing (or depth_m with density_kg_m3)");
  const double depth = r.Bounded(t, prefix, "depth_m", std::nullopt, kAssemblyMinSizeM, kAssemblyMaxSizeM, " m");
  const double density = r.Bounded(t, prefix, "density_kg_m3", std::nullopt, 1e-3, 1e6, " kg/m^3");
  return depth * width_m * height_m * density;
}

void ParseAssemblyBodies(AssemblyToml& r, const toml::array& list, const std::string& name, Assembly& a) {
  std::set<std::string> names;
  for (const toml::node& node : list) {
    const toml::table* t = node.as_table();
    if (t == nullptr) r.Fail(AssemblyToml::LineOf(node), "body", "must be an array of tables ([[body]])");
    AssemblyBody b;
    b.name = r.String(*t, "body", "name", std::nullopt);
    r.Check(!b.name.empty() && b.name.find_first_of(",\n\r\"") == std::string::npos, *t, "body", "name",
            "must be non-empty, without commas, quotes or line breaks (it names CSV rows)");
    r.Check(names.insert(b.name).second, *t, "body", "name", "repeats body '" + b.name + "'");
    if (t->contains("polygon")) {
      r.Check(list.size() == 1, *t, "body", "polygon",
              "is refused in a stack of " + std::to_string(list.size()) +
                  " bodies: the stack model takes rectangles (width_m, height_m); a polygon section "
                  "works in a one-body assembly");
      r.Check(!t->contains("width_m") && !t->contains("height_m"), *t, "body", "polygon",
              "is given with width_m/height_m: give one section");
      b.polygon_csv = AssemblyFolderOf(name, r.String(*t, "body", "polygon", std::nullopt));
      // The mass does not move a single block; its keys are still checked.
      if (t->contains("mass_kg") || t->contains("depth_m") || t->contains("density_kg_m3")) {
        AssemblyMass(r, *t, "body", 1.0, 1.0);
      }
    } else {
      b.width_m = r.Bounded(*t, "body", "width_m", std::nullopt, kAssemblyMinSizeM, kAssemblyMaxSizeM, " m");
      b.height_m = r.Bounded(*t, "body", "height_m", std::nullopt, kAssemblyMinSizeM, kAssemblyMaxSizeM, " m");
      b.mass_kg = AssemblyMass(r, *t, "body", b.width_m, b.height_m);
    }
    r.RejectUnknown(*t, "body");
    a.bodies.push_back(b);
  }
}

void ParseAssemblyFrame(AssemblyToml& r, const toml::table& t, Assembly& a) {
  model::stack::Frame f;
  f.columns = r.Int(t, "frame", "columns", std::nullopt, 1, 1000);
  f.column_width_m = r.Bounded(t, "frame", "column_width_m", std::nullopt, kAssemblyMinSizeM, kAssemblyMaxSizeM, " m");
  f.column_height_m =
      r.Bounded(t, "frame", "column_height_m", std::nullopt, kAssemblyMinSizeM, kAssemblyMaxSizeM, " m");
  f.column_mass_kg = r.Bounded(t, "frame", "column_mass_kg", std::nullopt, 1e-9, kAssemblyMaxMassKg, " kg");
  f.beam_mass_kg = r.Bounded(t, "frame", "beam_mass_kg", std::nullopt, 0.0, kAssemblyMaxMassKg, " kg");
  r.RejectUnknown(t, "frame");
  a.frame = f;
}

Assembly ParseAssemblyTable(const toml::table& root, const std::string& name) {
  AssemblyToml r(name, "an assembly");
  Assembly a;
  a.path = name;
  const toml::array* bodies = r.Array(root, "", "body");
  const toml::table* frame = r.Table(root, "", "frame", false);
  if (bodies != nullptr && frame != nullptr) r.Check(false, root, "", "frame", "is given with [[body]]: give one");
  if (bodies == nullptr && frame == nullptr) {
    r.Fail(1, "body", "is missing: an assembly is [[body]] tables (bottom-up) or a [frame] table");
  }
  if (bodies != nullptr) {
    r.Check(!bodies->empty() && static_cast<int>(bodies->size()) <= model::stack::kMaxBodies, root, "", "body",
            "must list 1 to " + std::to_string(model::stack::kMaxBodies) + " bodies");
    ParseAssemblyBodies(r, *bodies, name, a);
  } else {
    ParseAssemblyFrame(r, *frame, a);
  }
  if (const toml::array* interfaces = r.Array(root, "", "interface")) {
    r.Check(!a.frame, root, "", "interface",
            "is refused with [frame]: the frame's restitution comes from its momentum balance");
    r.Check(interfaces->size() <= a.bodies.size(), root, "", "interface",
            "lists " + std::to_string(interfaces->size()) + " interfaces for " + std::to_string(a.bodies.size()) +
                " bodies (one per joint, the first under the bottom body)");
    for (const toml::node& node : *interfaces) {
      const toml::table* t = node.as_table();
      if (t == nullptr) r.Fail(AssemblyToml::LineOf(node), "interface", "must be an array of tables ([[interface]])");
      const std::optional<double> e = r.OptionalDouble(*t, "interface", "restitution");
      r.Check(!e || (*e > 0 && *e <= 1), *t, "interface", "restitution", "must be in (0, 1]");
      a.restitution.push_back(e ? *e : -1.0);
      r.RejectUnknown(*t, "interface");
    }
  }
  r.RejectUnknown(root, "");
  return a;
}

}  // namespace

std::string Assembly::body_name(int k) const {
  return frame ? std::string("frame") : bodies[static_cast<std::size_t>(k)].name;
}

const char* Assembly::kind() const { return frame ? "frame" : (bodies.size() == 1 ? "block" : "stack"); }

Assembly ParseAssembly(const std::string& text, const std::string& name) {
  try {
    return ParseAssemblyTable(common::ParseTomlText(text, name, "the assembly file"), name);
  } catch (const OptionError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw OptionError(std::string("--assembly: ") + e.what());
  }
}

Assembly ReadAssembly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw OptionError("--assembly: cannot open '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return ParseAssembly(text.str(), path);
}

namespace {

model::BlockParams SingleBlockOf(const Assembly& a) {
  if (a.frame) return model::stack::FrameEquivalent(*a.frame);
  const AssemblyBody& b = a.bodies.front();
  model::BlockGeometry g;
  if (!b.polygon_csv.empty()) {
    try {
      g = model::PolygonBlock(model::ReadPolygonCsv(b.polygon_csv));
    } catch (const std::exception& e) {
      throw OptionError("--assembly: " + a.path + ": key 'body.polygon': " + e.what());
    }
    if (!g.symmetric) {
      throw OptionError("--assembly: " + a.path + ": key 'body.polygon': " + b.polygon_csv +
                        " is an asymmetric section, which the assembly path does not take (simulate's "
                        "single block has one alpha, p and mu)");
    }
  } else {
    g = model::RectangleBlock(b.width_m, b.height_m);
  }
  model::BlockParams params;
  params.alpha = g.alpha;
  params.p = g.p;
  params.mu = !a.restitution.empty() && a.restitution.front() > 0 ? a.restitution.front() : g.mu_general;
  return params;
}

}  // namespace

std::optional<model::BlockParams> EquivalentBlock(const Assembly& a) {
  if (!a.frame && a.bodies.size() != 1) return std::nullopt;
  const model::BlockParams params = SingleBlockOf(a);
  if (!(params.mu > 0 && params.mu <= 1)) {
    // Housner's (or the frame's) momentum balance gives no rebound for a
    // section this squat (alpha near pi/2): it does not rock.
    throw OptionError("--assembly: " + a.path + ": key '" + (a.frame ? "frame" : "body") +
                      "': a section this squat (alpha " + std::to_string(params.alpha) +
                      " rad) has restitution " + std::to_string(params.mu) +
                      " by the angular momentum rule, not in (0, 1]: it does not rock; give a slenderer section");
  }
  return params;
}

namespace {

// The single block's contact state: C at rest, R rocking on its +x corner
// (theta > 0: the stack's pivot right, whose angles are counter-clockwise),
// L on the -x one.
const char* SingleBlockMode(const model::ModelState& s) {
  if (s.regime == model::Regime::kRest) return "C";
  const double side = s.theta != 0.0 ? s.theta : s.theta_dot;
  return side > 0 ? "R" : "L";
}

// The state after a single block's event, from its values: an uplift under
// a table acceleration a < 0 starts theta > 0 (theta'' = -p^2 (sin(alpha -
// theta) + a/g cos(alpha - theta)) > 0 at theta = 0+ needs a < -g tan
// alpha); an impact leaves the rate of its value_after (the complex model's
// crossings, NaN, keep the one before); an overturn tips over the side of
// its angle.
const char* SingleBlockEventMode(const model::ModelEvent& e) {
  switch (e.kind) {
    case model::EventKind::kUplift:
      return e.value < 0 ? "R" : "L";
    case model::EventKind::kImpact: {
      const double rate = std::isnan(e.value_after) ? e.value : e.value_after;
      return rate > 0 ? "R" : (rate < 0 ? "L" : "C");
    }
    case model::EventKind::kOverturn:
      return e.value > 0 ? "R" : "L";
    case model::EventKind::kRest:
      break;
  }
  return "C";
}

void RunAssemblyAsBlock(const model::BlockParams& block, const ScenarioOptions& o, AssemblyRun& run) {
  ScenarioOptions single = o;
  single.alpha = block.alpha;
  single.p = block.p;
  single.mu = block.mu;
  single.theta0 = 0.0;
  Scenario s = BuildScenario(single);
  run.forcing_description = s.forcing_description;
  run.theta.assign(1, {});
  run.theta_dot.assign(1, {});
  const model::RockingModel& m = *s.model;
  RunScenario(s, single, [&](double t, double theta, double theta_dot) {
    run.time_s.push_back(t);
    run.theta[0].push_back(theta);
    run.theta_dot[0].push_back(theta_dot);
    run.mode.emplace_back(SingleBlockMode(m.state()));
  });
  for (const model::ModelEvent& e : m.events()) run.events.push_back({e.time_s, e.kind, 0, SingleBlockEventMode(e)});
  run.steps = m.solver_stats().steps;
}

std::vector<model::stack::Body> StackBodiesOf(const Assembly& a) {
  std::vector<model::stack::Body> bodies;
  for (const AssemblyBody& b : a.bodies) {
    bodies.push_back(model::stack::Body::Rectangle(b.width_m, b.height_m, b.mass_kg));
  }
  return bodies;
}

void RunAssemblyAsStack(const Assembly& a, const ScenarioOptions& o, const model::Forcing& forcing,
                        AssemblyRun& run, const model::CancelHook& cancelled = {}) {
  CheckAssemblyModel(a, o.model);
  Require(std::isfinite(o.rtol) && o.rtol > 0 && o.rtol <= 1e-3, "--rtol", "in (0, 1e-3]", o.rtol);
  const model::stack::Stack stack(StackBodiesOf(a));
  model::stack::RunOptions ro;
  ro.rtol = o.rtol;
  ro.rate_hz = o.rate_hz;
  ro.duration_s = o.duration_s;
  ro.restitution = a.restitution;
  ro.cancelled = cancelled;
  const model::stack::Run r = model::stack::Simulate(stack, forcing, ro);
  const int n = stack.bodies();
  run.theta.assign(static_cast<std::size_t>(n), {});
  run.theta_dot.assign(static_cast<std::size_t>(n), {});
  run.time_s = r.time_s;
  for (std::size_t i = 0; i < r.time_s.size(); ++i) {
    for (int k = 0; k < n; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      // The single block's sign, clockwise positive (0 - x: +0 at rest, not -0).
      run.theta[kk].push_back(0.0 - r.theta[i][kk]);
      run.theta_dot[kk].push_back(0.0 - r.theta_dot[i][kk]);
    }
    run.mode.push_back(model::stack::ModeName(r.mode[i], n));
  }
  for (const model::stack::Event& e : r.events) {
    run.events.push_back({e.time_s, e.kind, e.interface, model::stack::ModeName(e.after, n)});
  }
  run.steps = r.steps;
  run.impacts_preload = r.impacts_preload;
  run.impacts_held_pivots = r.impacts_held_pivots;
}

}  // namespace

void CheckAssemblyModel(const Assembly& a, const std::string& model) {
  const model::ModelInfo* info = model::FindModel(model);
  if (info == nullptr) {
    throw OptionError("--model must be " + model::ModelNames(" or ") + ", got '" + model + "'");
  }
  if (!a.frame && static_cast<int>(a.bodies.size()) > info->max_bodies) {
    throw OptionError("--model " + model + " with the stack of " + std::to_string(a.bodies.size()) + " bodies in " +
                      a.path +
                      ": only housner takes a stack (eq. (10)'s extension to several bodies is not derived, "
                      "docs/models.md, \"Assemblies\"); a frame or a one-body assembly takes complex");
  }
}

model::stack::Stack StackOf(const Assembly& a) {
  if (a.frame || a.bodies.size() < 2) {
    throw OptionError("--assembly: " + a.path + ": a " + a.kind() + " is run as its single block, not as a stack");
  }
  return model::stack::Stack(StackBodiesOf(a));
}

void ResolveAssemblyVariant(model::VariantSpec& v) {
  const Assembly a = ReadAssembly(v.assembly_path);
  CheckAssemblyModel(a, model::ToString(v.kind));
  if (const std::optional<model::BlockParams> block = EquivalentBlock(a)) {
    v.params = *block;
    return;
  }
  v.stack = StackOf(a);
  v.restitution = a.restitution;
  v.body_names.clear();
  for (int k = 0; k < a.output_bodies(); ++k) v.body_names.push_back(a.body_name(k));
  v.params = StackRowParams(a);
}

AssemblyRun RunStackUnder(const Assembly& a, const ScenarioOptions& o, const model::Forcing& forcing,
                          const std::string& forcing_description, const model::CancelHook& cancelled) {
  if (a.frame || a.bodies.size() < 2) {
    throw OptionError("--assembly: " + a.path + ": a " + a.kind() + " is run as its single block, not as a stack");
  }
  AssemblyRun run;
  run.kind = a.kind();
  for (int k = 0; k < a.output_bodies(); ++k) run.names.push_back(a.body_name(k));
  run.forcing_description = forcing_description;
  RunAssemblyAsStack(a, o, forcing, run, cancelled);
  return run;
}

model::BlockParams StackRowParams(const Assembly& a) {
  if (a.frame || a.bodies.size() < 2) {
    throw OptionError("--assembly: " + a.path + ": a " + a.kind() + " is named by its single block");
  }
  const model::stack::Stack stack(StackBodiesOf(a));
  const int n = stack.bodies();
  // Centres' heights above the table and the interfaces' heights, m.
  std::vector<double> z_centre(static_cast<std::size_t>(n)), z_face(static_cast<std::size_t>(n));
  double z = 0.0;
  for (int i = 0; i < n; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    z_face[ii] = z;
    z_centre[ii] = z + stack.body(i).half_height_m;
    z += 2 * stack.body(i).half_height_m;
  }
  // Uplift from rest at interface k (docs/sweep.md, "Assemblies"): the
  // table's push a on the bodies above turns them about a corner of the
  // face once a M_k (first moment) exceeds g c_k M_k: a/g > c_k M_k / S_k.
  double tan_alpha = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    double mass = 0.0, moment = 0.0;
    for (int j = k; j < n; ++j) {
      mass += stack.body(j).mass_kg;
      moment += stack.body(j).mass_kg * (z_centre[static_cast<std::size_t>(j)] - z_face[static_cast<std::size_t>(k)]);
    }
    tan_alpha = std::min(tan_alpha, stack.contact_half_width_m(k) * mass / moment);
  }
  // The stack as one body about its base corner (-c_0, 0).
  const double c0 = stack.contact_half_width_m(0);
  double mass = 0.0, moment = 0.0, inertia = 0.0;
  for (int j = 0; j < n; ++j) {
    const model::stack::Body& b = stack.body(j);
    const double zj = z_centre[static_cast<std::size_t>(j)];
    mass += b.mass_kg;
    moment += b.mass_kg * zj;
    inertia += b.inertia_kgm2 + b.mass_kg * (c0 * c0 + zj * zj);
  }
  const double z_g = moment / mass;
  const double r = std::hypot(c0, z_g);
  model::BlockParams params;
  params.alpha = std::atan(tan_alpha);
  params.p = std::sqrt(mass * common::kGravity * r / inertia);
  params.mu = !a.restitution.empty() && a.restitution.front() > 0 ? a.restitution.front()
                                                                   : 1 - 2 * mass * c0 * c0 / inertia;
  return params;
}

AssemblyRun RunAssembly(const Assembly& a, const ScenarioOptions& o) {
  Require(std::isfinite(o.duration_s) && o.duration_s >= 0, "--duration", ">= 0 s", o.duration_s);
  Require(std::isfinite(o.rate_hz) && o.rate_hz > 0, "--rate", "> 0 Hz", o.rate_hz);
  Require(o.duration_s * o.rate_hz < kAssemblyMaxRows, "--duration",
          "such that duration * rate < 1e7 rows (an assembly's run is held in memory)", o.duration_s);
  AssemblyRun run;
  run.kind = a.kind();
  for (int k = 0; k < a.output_bodies(); ++k) run.names.push_back(a.body_name(k));
  run.block = EquivalentBlock(a);
  if (run.block) {
    RunAssemblyAsBlock(*run.block, o, run);
  } else {
    CheckAssemblyModel(a, o.model);
    const std::unique_ptr<model::Forcing> forcing = BuildForcing(o, run.forcing_description);
    RunAssemblyAsStack(a, o, *forcing, run);
  }
  return run;
}

AssemblySummary Summarise(const AssemblyRun& run) {
  AssemblySummary s;
  s.peak_abs_theta.assign(run.names.size(), 0.0);
  s.peak_time_s.assign(run.names.size(), 0.0);
  for (std::size_t k = 0; k < run.names.size(); ++k) {
    for (std::size_t i = 0; i < run.time_s.size(); ++i) {
      if (std::abs(run.theta[k][i]) > s.peak_abs_theta[k]) {
        s.peak_abs_theta[k] = std::abs(run.theta[k][i]);
        s.peak_time_s[k] = run.time_s[i];
      }
    }
  }
  for (std::size_t i = 0; i < run.mode.size(); ++i) {
    s.modes.insert(run.mode[i]);
    if (i > 0 && run.mode[i] != run.mode[i - 1]) ++s.mode_changes;
  }
  for (const AssemblyEvent& e : run.events) {
    if (e.kind == model::EventKind::kUplift && !s.uplift_time_s) s.uplift_time_s = e.time_s;
    if (e.kind == model::EventKind::kImpact) ++s.impacts;
    if (e.kind == model::EventKind::kOverturn && !s.overturn_time_s) {
      s.overturn_time_s = e.time_s;
      s.overturned_body = run.names[static_cast<std::size_t>(e.interface)];
    }
  }
  return s;
}

std::string AssemblySummaryJson(const ScenarioOptions& o, const std::string& path, const AssemblyRun& run,
                                const AssemblySummary& s, double cpu_s) {
  auto optional = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); };
  const nlohmann::json overturned_body =
      s.overturn_time_s ? nlohmann::json(s.overturned_body) : nlohmann::json(nullptr);
  auto block = [&run](double model::BlockParams::*field) {
    return run.block ? nlohmann::json((*run.block).*field) : nlohmann::json(nullptr);
  };
  nlohmann::json bodies = nlohmann::json::array();
  for (std::size_t k = 0; k < run.names.size(); ++k) {
    bodies.push_back(
        {{"name", run.names[k]}, {"peak_abs_theta", s.peak_abs_theta[k]}, {"peak_time", s.peak_time_s[k]}});
  }
  const nlohmann::json j = {{"assembly", path},
                           {"kind", run.kind},
                           {"model", o.model},
                           {"alpha", block(&model::BlockParams::alpha)},
                           {"p", block(&model::BlockParams::p)},
                           {"mu", block(&model::BlockParams::mu)},
                           {"excitation", run.forcing_description},
                           {"duration", o.duration_s},
                           {"rate", o.rate_hz},
                           {"samples", run.time_s.size()},
                           {"bodies", bodies},
                           {"uplift_time", optional(s.uplift_time_s)},
                           {"impacts", s.impacts},
                           {"overturned", s.overturn_time_s.has_value()},
                           {"overturned_body", overturned_body},
                           {"overturn_time", optional(s.overturn_time_s)},
                           {"modes", s.modes.size()},
                           {"mode_changes", s.mode_changes},
                           {"final_mode", run.mode.empty() ? nlohmann::json(nullptr) : nlohmann::json(run.mode.back())},
                           {"events", run.events.size()},
                           {"steps", run.steps},
                           {"impacts_preload", run.impacts_preload},
                           {"impacts_held_pivots", run.impacts_held_pivots},
                           {"cpu_time", cpu_s},
                           {"units",
                            {{"alpha", "rad"}, {"p", "rad/s"}, {"duration", "s"}, {"rate", "Hz"}, {"uplift_time", "s"},
                             {"peak_abs_theta", "rad"}, {"peak_time", "s"}, {"overturn_time", "s"},
                             {"cpu_time", "s"}}}};
  return j.dump(2);
}

}  // namespace rocklab::pipeline
