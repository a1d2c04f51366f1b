#include "sweep/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <stdexcept>

#include "common/provenance.h"
#include "common/text.h"
#include "common/units.h"
#include "model/excitation.h"
#include "model/model_registry.h"
#include "pipeline/option_error.h"
#include "pipeline/scenario.h"

namespace rocklab::sweep {
namespace {

using pipeline::OptionError;
using pipeline::Require;

// Numbers in rows: 12 significant digits, the same text for the same double
// on every machine and thread (printf of an IEEE double is exact to the
// digits asked for).
void Append(std::string& out, double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  out += buf;
}

bool FieldSafe(const std::string& s) {
  return std::none_of(s.begin(), s.end(), [](char c) {
    return c == ',' || c == '"' || static_cast<unsigned char>(c) < 0x20;
  });
}

double Duration(const Plan& plan, const Record& record) {
  return plan.duration_s ? *plan.duration_s : record.time_s.back() + Plan::kDefaultTail_s;
}

// FNV-1a, 64 bits, continued over `size` bytes.
void Fnv1aBytes(std::uint64_t& h, const unsigned char* bytes, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) {
    h ^= bytes[i];
    h *= 0x100000001b3ULL;
  }
}

std::string Hex64(std::uint64_t h) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

// --assembly: the file read, its model checked, its one row block (the
// single block of a body or a frame, a stack's StackRowParams) and its
// identity for the definition.
void PlanAssembly(const PlanOptions& o, Plan& plan) {
  pipeline::Assembly a = pipeline::ReadAssembly(o.assembly);
  pipeline::CheckAssemblyModel(a, o.model);
  for (int k = 0; k < a.output_bodies(); ++k) {
    if (!FieldSafe(a.body_name(k))) {
      throw OptionError("--assembly: " + o.assembly + ": key 'body.name': '" + a.body_name(k) +
                        "' names a CSV field: give it without control characters");
    }
  }
  const std::string label = std::filesystem::path(o.assembly).filename().string();
  if (!FieldSafe(label)) {
    throw OptionError("--assembly: '" + o.assembly + "': rename it without ',', '\"' or control characters");
  }
  const std::optional<model::BlockParams> single = pipeline::EquivalentBlock(a);
  plan.blocks.push_back({single ? *single : pipeline::StackRowParams(a), label});
  std::ifstream in(o.assembly, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::uint64_t h = 0xcbf29ce484222325ULL;
  Fnv1aBytes(h, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  plan.assembly_identity = label + " " + std::to_string(bytes.size()) + " fnv1a64:" + Hex64(h);
  plan.assembly = std::move(a);
}

}  // namespace

Record ReadRecord(const std::string& path) {
  Record r;
  r.path = path;
  r.name = std::filesystem::path(path).filename().string();
  if (!FieldSafe(r.name)) {
    throw OptionError("--records: '" + path + "': a record's file name becomes a CSV field; "
                      "rename it without ',', '\"' or control characters");
  }
  model::AccelerationRows rows;
  try {
    rows = model::ReadAccelerationRows(path);
  } catch (const std::exception& e) {
    throw OptionError(std::string("--records: ") + e.what());
  }
  r.time_s = std::move(rows.time_s);
  r.accel_mps2 = std::move(rows.accel_mps2);
  for (double a : r.accel_mps2) r.pga_mps2 = std::max(r.pga_mps2, std::abs(a));
  if (!(r.pga_mps2 > 0)) {
    throw OptionError("--records: " + path + ": every acceleration is zero (PGA 0): nothing to scale");
  }
  return r;
}

std::vector<double> ParseScaleGrid(const std::string& text) {
  const std::string what = "--scale must be A:B:N (from A to B in N steps), got '" + text + "'";
  const auto c1 = text.find(':');
  const auto c2 = c1 == std::string::npos ? c1 : text.find(':', c1 + 1);
  if (c2 == std::string::npos || text.find(':', c2 + 1) != std::string::npos) throw OptionError(what);
  double a = 0, b = 0, n = 0;
  if (!common::ParseDouble(std::string_view(text).substr(0, c1), a) ||
      !common::ParseDouble(std::string_view(text).substr(c1 + 1, c2 - c1 - 1), b) ||
      !common::ParseDouble(std::string_view(text).substr(c2 + 1), n)) {
    throw OptionError(what);
  }
  Require(std::isfinite(a) && a > 0, "--scale A", "> 0", a);
  Require(std::isfinite(b) && b > 0, "--scale B", "> 0", b);
  Require(n >= 1 && n <= 1e6 && n == std::floor(n), "--scale N", "a whole number in [1, 1e6]", n);
  const auto count = static_cast<std::size_t>(n);
  std::vector<double> grid(count);
  for (std::size_t k = 0; k < count; ++k) {
    grid[k] = count == 1 ? a : a + (b - a) * static_cast<double>(k) / static_cast<double>(count - 1);
  }
  return grid;
}

Plan MakePlan(const PlanOptions& o) {
  Plan plan;
  try {
    plan.model = model::ParseModelKind(o.model);
  } catch (const std::invalid_argument&) {
    throw OptionError("--model must be " + model::ModelNames(" or ") + ", got '" + o.model + "'");
  }
  if (o.records.empty()) throw OptionError("--records: give at least one record file");
  plan.scales = ParseScaleGrid(o.scale);
  plan.scale_kind = o.pga_g ? ScaleKind::kPgaG : ScaleKind::kFactor;
  if (o.duration_s) {
    Require(std::isfinite(*o.duration_s) && *o.duration_s > 0 && *o.duration_s < 1e6, "--duration",
            "in (0, 1e6) s", *o.duration_s);
    plan.duration_s = o.duration_s;
  }
  Require(std::isfinite(o.rate_hz) && o.rate_hz > 0 && o.rate_hz <= 1e6, "--rate", "in (0, 1e6] Hz", o.rate_hz);
  Require(std::isfinite(o.l) && o.l > 0, "--l", "> 0", o.l);
  plan.rate_hz = o.rate_hz;
  plan.l = o.l;
  Require(std::isfinite(o.rtol) && o.rtol > 0 && o.rtol <= 1e-3, "--rtol", "in (0, 1e-3]", o.rtol);
  plan.rtol = o.rtol;

  const bool by_params = !o.alpha.empty() || !o.p.empty() || !o.mu.empty();
  const bool by_rect = !o.width.empty() || !o.height.empty();
  const bool by_polygon = !o.polygons.empty();
  const bool by_assembly = !o.assembly.empty();
  if (int(by_params) + int(by_rect) + int(by_polygon) + int(by_assembly) != 1) {
    throw OptionError("give the blocks one way: --alpha/--p/--mu, --width/--height, or --polygon (or one --assembly)");
  }
  if (by_assembly) {
    PlanAssembly(o, plan);
  } else if (by_params) {
    if (o.alpha.empty() || o.p.empty()) throw OptionError("--alpha and --p both need at least one value");
    for (double a : o.alpha) {
      Require(std::isfinite(a) && a > 0 && a < common::kPi / 2, "--alpha", "in (0, pi/2) rad", a);
      for (double p : o.p) {
        Require(std::isfinite(p) && p > 0, "--p", "> 0 rad/s", p);
        const std::vector<double> mus =
            o.mu.empty() ? std::vector<double>{1 - 1.5 * std::sin(a) * std::sin(a)} : o.mu;
        for (double mu : mus) {
          Require(std::isfinite(mu) && mu > 0 && mu <= 1, "--mu", "in (0, 1]", mu);
          plan.blocks.push_back({model::BlockParams{a, p, mu}, "-"});
        }
      }
    }
  } else if (by_rect) {
    if (o.width.empty() || o.height.empty()) throw OptionError("--width and --height both need at least one value");
    for (double w : o.width) {
      for (double h : o.height) {
        model::BlockGeometry g;
        try {
          g = model::RectangleBlock(w, h);
        } catch (const std::invalid_argument& e) {
          throw OptionError(std::string("--width/--height: ") + e.what());
        }
        std::string label;
        Append(label, w);
        label += 'x';
        Append(label, h);
        plan.blocks.push_back({g.params(), label});
      }
    }
  } else {
    for (const std::string& path : o.polygons) {
      model::BlockGeometry g;
      try {
        g = model::PolygonBlock(model::ReadPolygonCsv(path));
      } catch (const std::invalid_argument& e) {
        throw OptionError(std::string("--polygon: ") + e.what());
      }
      const std::string label = std::filesystem::path(path).filename().string();
      if (!FieldSafe(label)) {
        throw OptionError("--polygon: '" + path + "': rename it without ',', '\"' or control characters");
      }
      plan.blocks.push_back({g.params(), label});
    }
  }

  std::set<std::string> names;
  for (const std::string& path : o.records) {
    plan.records.push_back(ReadRecord(path));
    if (!names.insert(plan.records.back().name).second) {
      throw OptionError("--records: two records are named '" + plan.records.back().name +
                        "' (the record column would not tell them apart): rename one");
    }
  }
  if (plan.stack()) {
    // A stack's run is held whole (pipeline::RunStackUnder), as simulate's.
    for (const Record& r : plan.records) {
      Require(Duration(plan, r) * plan.rate_hz < 1e7, "--duration",
              "such that duration * rate < 1e7 samples for a stack (its run is held in memory)", Duration(plan, r));
    }
  }
  if (plan.size() > 100'000'000) {
    throw OptionError("the sweep has " + std::to_string(plan.size()) + " cases, more than 1e8");
  }
  return plan;
}

CaseIndex Locate(const Plan& plan, std::size_t index) {
  CaseIndex c;
  c.scale = index % plan.scales.size();
  const std::size_t rb = index / plan.scales.size();
  c.block = rb % plan.blocks.size();
  c.record = rb / plan.blocks.size();
  return c;
}

Scaling ScalingOf(const Plan& plan, std::size_t index) {
  const CaseIndex c = Locate(plan, index);
  const Record& r = plan.records[c.record];
  const double grid = plan.scales[c.scale];
  Scaling s;
  if (plan.scale_kind == ScaleKind::kPgaG) {
    s.pga_g = grid;
    s.factor = grid * common::kGravity / r.pga_mps2;
  } else {
    s.factor = grid;
    s.pga_g = grid * r.pga_mps2 / common::kGravity;
  }
  return s;
}

namespace {

// A case of a stack: pipeline::RunStackUnder (simulate --assembly's stack
// path) under the scaled record. The stack model polls the token every
// model::stack::kCancelPollOutputs samples, as RunCase's block every 256.
Outcome RunStackCase(const Plan& plan, std::size_t index, const common::CancelToken* token) {
  const CaseIndex c = Locate(plan, index);
  const Record& record = plan.records[c.record];
  const Scaling scaling = ScalingOf(plan, index);
  std::vector<double> accel(record.accel_mps2);
  for (double& a : accel) a *= scaling.factor;
  const model::SampledAcceleration forcing(record.time_s, std::move(accel));
  pipeline::ScenarioOptions so;
  so.model = model::ToString(plan.model);
  so.l = plan.l;
  so.rtol = plan.rtol;
  so.duration_s = Duration(plan, record);
  so.rate_hz = plan.rate_hz;
  if (token != nullptr) token->ThrowIfCancelled();
  model::CancelHook cancelled;
  if (token != nullptr) cancelled = [token] { return token->Check(); };
  pipeline::AssemblyRun run;
  try {
    run = pipeline::RunStackUnder(*plan.assembly, so, forcing, "accel:" + record.path, cancelled);
  } catch (const common::Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    throw std::runtime_error("case " + std::to_string(index) + " (" + KeyPrefix(plan, index) + "...): " + e.what());
  }
  if (token != nullptr) token->ThrowIfCancelled();
  // theta / alpha with the row's alpha (the stack's uplift angle), over
  // every body: the existing columns keep their meaning for the assembly.
  const double alpha = plan.blocks[c.block].params.alpha;
  Outcome out;
  for (std::size_t k = 0; k < run.names.size(); ++k) {
    for (std::size_t i = 0; i < run.time_s.size(); ++i) {
      const double a = std::abs(run.theta[k][i]);
      out.peak_abs_theta_rad[k] = std::max(out.peak_abs_theta_rad[k], a);
      if (a / alpha > out.peak_theta_over_alpha) {
        out.peak_theta_over_alpha = a / alpha;
        out.peak_time_s = run.time_s[i];
      }
    }
  }
  for (const pipeline::AssemblyEvent& e : run.events) {
    if (e.kind == model::EventKind::kUplift && !out.uplift_time_s) out.uplift_time_s = e.time_s;
    if (e.kind == model::EventKind::kImpact) ++out.impacts;
    if (e.kind == model::EventKind::kOverturn && !out.overturned) {
      out.overturned = true;
      out.overturn_time_s = e.time_s;
      out.first_overturned = e.interface;  // the body on the interface that reached pi/2
    }
  }
  if (out.overturned) out.peak_theta_over_alpha = (common::kPi / 2) / alpha;
  return out;
}

}  // namespace

Outcome RunCase(const Plan& plan, std::size_t index, const common::CancelToken* token) {
  if (plan.stack()) return RunStackCase(plan, index, token);
  const CaseIndex c = Locate(plan, index);
  const Record& record = plan.records[c.record];
  const Block& block = plan.blocks[c.block];
  const Scaling scaling = ScalingOf(plan, index);

  std::vector<double> accel(record.accel_mps2);
  for (double& a : accel) a *= scaling.factor;
  const model::ModelOptions mo = CaseModelOptions(plan);
  pipeline::Scenario scenario;
  scenario.model = model::RockingModel::Create(plan.model, block.params, mo);
  scenario.forcing = std::make_unique<model::SampledAcceleration>(record.time_s, std::move(accel));
  scenario.forcing_description = "accel:" + record.path;
  pipeline::ScenarioOptions so;
  so.model = model::ToString(plan.model);
  so.alpha = block.params.alpha;
  so.p = block.params.p;
  so.mu = block.params.mu;
  so.l = plan.l;
  so.rtol = plan.rtol;
  so.duration_s = Duration(plan, record);
  so.rate_hz = plan.rate_hz;

  // theta / alpha of the side it rocks on (both sides alike for a symmetric block).
  const double alpha_plus = block.params.Side(+1).alpha, alpha_minus = block.params.Side(-1).alpha;
  Outcome out;
  pipeline::RunSummary summary;
  double last_theta = 0.0;  // rad; after an overturn, the side it fell to
  double peak_abs_theta = 0.0;  // rad
  unsigned unpolled = 0;    // output samples since the token was last polled
  try {
    summary = pipeline::RunScenario(scenario, so, [&](double t, double theta, double) {
      if (token != nullptr && ++unpolled == 256) {
        unpolled = 0;
        token->ThrowIfCancelled();
      }
      last_theta = theta;
      peak_abs_theta = std::max(peak_abs_theta, std::abs(theta));
      const double ratio = theta >= 0 ? theta / alpha_plus : -theta / alpha_minus;
      if (ratio > out.peak_theta_over_alpha) {
        out.peak_theta_over_alpha = ratio;
        out.peak_time_s = t;
      }
    });
  } catch (const common::Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    throw std::runtime_error("case " + std::to_string(index) + " (" + KeyPrefix(plan, index) + "...): " + e.what());
  }
  out.overturned = summary.overturned;
  // docs/sweep.md: (pi/2) / alpha once overturned. The complex model's state
  // frozen at its overturn has theta = r cos(psi), short of pi/2 by the
  // psi that finite l leaves (4.5620 against 4.5652 for alpha 0.344).
  if (out.overturned) out.peak_theta_over_alpha = (common::kPi / 2) / (last_theta >= 0 ? alpha_plus : alpha_minus);
  out.beyond_pi_over_2 = !summary.overturned && summary.peak_abs_theta > common::kPi / 2;
  out.overturn_time_s = summary.overturn_time_s.value_or(0.0);
  out.impacts = summary.impacts;
  out.uplift_time_s = summary.uplift_time_s;
  out.peak_abs_theta_rad[0] = peak_abs_theta;
  if (out.overturned) out.first_overturned = 0;
  return out;
}

model::ModelOptions CaseModelOptions(const Plan& plan) {
  model::ModelOptions mo;
  mo.l = plan.l;
  mo.rtol = plan.rtol;
  // A case is `rocklab simulate`'s run to the bit: its integrator per model
  // as pipeline::BuildScenario chooses it.
  mo.integrator = model::FindModel(plan.model).batch_integrator;
  return mo;
}

namespace {

std::string Exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// FNV-1a, 64 bits, over the bytes of the doubles as this machine holds them
// (IEEE 754; little-endian on every platform rocklab builds for).
void Fnv1a(std::uint64_t& h, const std::vector<double>& values) {
  for (double v : values) {
    unsigned char bytes[sizeof v];
    std::memcpy(bytes, &v, sizeof v);
    Fnv1aBytes(h, bytes, sizeof bytes);
  }
}

bool KeyChar(char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; }

}  // namespace

Definition DefinitionOf(const Plan& plan) {
  const model::ModelOptions mo = CaseModelOptions(plan);
  Definition d = {
      {"model", model::ToString(plan.model)},
      {"integrator", model::ToString(mo.integrator)},
      {"rtol", Exact(mo.rtol)},
      {"atol", Exact(mo.atol)},
      {"max_step_s", Exact(mo.max_step_s)},
      {"rest_impact_interval_s", Exact(mo.rest_impact_interval_s)},
      {"l", Exact(mo.l)},
      {"rate_hz", Exact(plan.rate_hz)},
      {"duration_s", plan.duration_s ? Exact(*plan.duration_s)
                                     : "record end + " + Exact(Plan::kDefaultTail_s)},
      {"scale_kind", plan.scale_kind == ScaleKind::kPgaG ? "pga_g" : "factor"},
      {"cases", std::to_string(plan.records.size()) + " records x " + std::to_string(plan.blocks.size()) +
                    " blocks x " + std::to_string(plan.scales.size()) + " scales"},
      {"records", std::to_string(plan.records.size())},
  };
  for (std::size_t k = 0; k < plan.records.size(); ++k) {
    const Record& r = plan.records[k];
    std::uint64_t h = 0xcbf29ce484222325ULL;
    Fnv1a(h, r.time_s);
    Fnv1a(h, r.accel_mps2);
    d.push_back({"record_" + std::to_string(k + 1),
                 r.name + " " + std::to_string(r.time_s.size()) + " fnv1a64:" + Hex64(h)});
  }
  // A stack runs the stack model (model::stack::RunOptions' defaults but
  // rtol), not the single block's integrator: its own knobs, "-" for those
  // it has none of.
  if (plan.stack()) {
    const model::stack::RunOptions so;
    for (DefinitionField& f : d) {
      if (f.key == "integrator") f.value = "stack_cvode_adams";
      if (f.key == "atol") f.value = Exact(so.atol_rad);
      if (f.key == "max_step_s" || f.key == "rest_impact_interval_s") f.value = "-";
    }
  }
  // Only with --assembly: a sweep of blocks keeps its definition's bytes.
  if (plan.assembly) {
    d.push_back({"assembly", plan.assembly_identity});
    d.push_back({"assembly_bodies", std::to_string(plan.bodies())});
  }
  return d;
}

constexpr const char* kDefinitionTitle = "# rocklab sweep definition";

std::string DefinitionText(const Definition& d) {
  std::string out = std::string(kDefinitionTitle) + "\n";
  for (const DefinitionField& f : d) out += "# " + f.key + ": " + f.value + "\n";
  return out;
}

// ProvenanceText's title line, as common::ProvenanceCommentLines writes it.
constexpr const char* kProvenanceTitle =
    "# rocklab provenance (not part of the definition: it differs between runs and shards)";
constexpr const char* kProvenancePrefix = "# provenance.";

std::string ProvenanceText(const ProvenanceLines& p) {
  return common::ProvenanceCommentLines(p, std::string(kProvenanceTitle).substr(2));
}

bool ParseDefinitionLine(const std::string& line, Definition& d) {
  if (line == kDefinitionTitle) return true;
  // Provenance lines (ProvenanceText) sit among the definition's, outside it.
  if (line == kProvenanceTitle || line.rfind(kProvenancePrefix, 0) == 0) return true;
  if (line.size() < 2 || line[0] != '#' || line[1] != ' ') return false;
  const std::size_t colon = line.find(": ", 2);
  if (colon == std::string::npos || colon == 2) return false;
  const std::string key = line.substr(2, colon - 2);
  if (!std::all_of(key.begin(), key.end(), KeyChar)) return false;
  d.push_back({key, line.substr(colon + 2)});
  return true;
}

std::string FirstDifference(const Definition& a, const Definition& b, std::string& a_value, std::string& b_value) {
  const auto find = [](const Definition& d, const std::string& key) -> const std::string* {
    for (const DefinitionField& f : d) {
      if (f.key == key) return &f.value;
    }
    return nullptr;
  };
  for (const Definition* first : {&a, &b}) {
    for (const DefinitionField& f : *first) {
      const std::string* in_a = find(a, f.key);
      const std::string* in_b = find(b, f.key);
      if (in_a == nullptr || in_b == nullptr || *in_a != *in_b) {
        a_value = in_a ? *in_a : "(none)";
        b_value = in_b ? *in_b : "(none)";
        return f.key;
      }
    }
  }
  return "";
}

const std::string& Header() {
  static const std::string header =
      "record,scale,pga_g,alpha,p,mu,model,peak_theta_over_alpha,overturned,overturn_time,impacts,"
      "uplift_time,peak_time,block,alpha_minus,p_minus,mu_minus";
  return header;
}

std::string HeaderOf(const Plan& plan) {
  std::string header = Header();
  if (!plan.assembly) return header;
  header += ",first_overturned_body";
  for (int k = 1; k <= plan.bodies(); ++k) header += ",peak_abs_theta_" + std::to_string(k);
  return header;
}

std::string KeyPrefix(const Plan& plan, std::size_t index) {
  const CaseIndex c = Locate(plan, index);
  const Scaling s = ScalingOf(plan, index);
  const model::BlockParams& b = plan.blocks[c.block].params;
  std::string out = plan.records[c.record].name;
  for (double v : {s.factor, s.pga_g, b.alpha, b.p, b.mu}) {
    out += ',';
    Append(out, v);
  }
  out += ',';
  out += model::ToString(plan.model);
  out += ',';
  return out;
}

std::string FormatRow(const Plan& plan, std::size_t index, const Outcome& o) {
  std::string out = KeyPrefix(plan, index);
  out.reserve(256);
  Append(out, o.peak_theta_over_alpha);
  out += o.overturned ? ",1," : ",0,";
  if (o.overturned) Append(out, o.overturn_time_s);
  out += ',' + std::to_string(o.impacts) + ',';
  if (o.uplift_time_s) Append(out, *o.uplift_time_s);
  out += ',';
  Append(out, o.peak_time_s);
  const Block& block = plan.blocks[Locate(plan, index).block];
  out += ',' + block.label + ',';
  if (block.params.minus) {
    Append(out, block.params.minus->alpha);
    out += ',';
    Append(out, block.params.minus->p);
    out += ',';
    Append(out, block.params.minus->mu);
  } else {
    out += ",";
    out += ",";
  }
  if (plan.assembly) {
    out += ',';
    if (o.first_overturned >= 0) out += plan.assembly->body_name(o.first_overturned);
    for (int k = 0; k < plan.bodies(); ++k) {
      out += ',';
      Append(out, o.peak_abs_theta_rad[static_cast<std::size_t>(k)]);
    }
  }
  out += '\n';
  return out;
}

}  // namespace rocklab::sweep
