// rocklab synth: the rig simulator. Runs a model scenario (the options of
// `rocklab simulate`), turns the block's and the table's motion into raw
// channel values through the inverse measurement models of the rig
// (daq/rig_simulator.h) with seeded noise, LED occlusions, dropped samples
// and optional slip / twist faults, and writes the raw file and the truth.
// With --assembly the motion is an assembly's (pipeline/assembly.h), each
// body's LEDs moved with it (a rig of several [[body]] tables).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/provenance.h"
#include "daq/rig_simulator.h"
#include "model/table_motion.h"
#include "pipeline/assembly.h"
#include "pipeline/pipeline.h"
#include "pipeline/scenario.h"
#include "pipeline/scenario_flags.h"
#include "tools/cli.h"
#include "tools/formats.h"
#include "tools/simulate_assembly.h"

namespace rocklab::tools {
namespace {

struct Fault {
  double size{};    ///< m (slip) or rad (twist)
  double time_s{};  ///< s
  std::string body;  ///< the optional third part: the body that slides on the one below (--slip) or twists (--twist)
};

struct SynthOptions {
  std::string rig_path;
  pipeline::ScenarioOptions scenario;
  double noise_scale{1.0};
  double occlusion{daq::SimulatorNoise::Typical().occlusion};
  double drop{daq::SimulatorNoise::Typical().drop};
  std::string slip_text;
  std::string twist_text;
  uint64_t seed{1};
  bool decimal_comma{};
  std::string out;
  std::string truth_csv;
  bool json{};
  double hold_s{0.0};  ///< the block held at theta0 (table at rest) this long before the scenario starts, s
  std::string assembly_toml;  ///< --assembly: the motion of an assembly's bodies
};

// "SIZE@TIME" or "SIZE@TIME@BODY" -> Fault; throws UsageError naming the
// option.
std::optional<Fault> ParseFault(const std::string& text, const std::string& option) {
  if (text.empty()) return std::nullopt;
  const size_t at = text.find('@');
  Fault f;
  try {
    if (at == std::string::npos) throw std::invalid_argument("no @");
    size_t used = 0;
    f.size = std::stod(text.substr(0, at), &used);
    if (used != at) throw std::invalid_argument("size");
    std::string time = text.substr(at + 1);
    const size_t second = time.find('@');
    if (second != std::string::npos) {
      f.body = time.substr(second + 1);
      time.resize(second);
      if (f.body.empty()) throw std::invalid_argument("body");
    }
    f.time_s = std::stod(time, &used);
    if (used != time.size()) throw std::invalid_argument("time");
  } catch (const std::exception&) {
    // The body form is named only where it was tried (the message is older than it).
    const bool tried_body = text.find('@', at == std::string::npos ? 0 : at + 1) != std::string::npos;
    throw UsageError(option + " must be SIZE@TIME_S (e.g. 0.003@2.5)" +
                     (tried_body ? std::string(" or SIZE@TIME_S@BODY (a body of the rig's [[body]] tables)") : "") +
                     ", got '" + text + "'");
  }
  Require(std::isfinite(f.size), option, "a finite size", f.size);
  Require(std::isfinite(f.time_s) && f.time_s >= 0, option, "a time >= 0 s", f.time_s);
  return f;
}

// The index of the rig's body a fault names with @BODY; without one the
// bottom body (0). Throws UsageError naming the option and the rig.
int FaultBody(const std::optional<Fault>& fault, const daq::RigConfig& rig, const std::string& option) {
  if (!fault || fault->body.empty()) return 0;
  for (std::size_t k = 0; rig.multi_body() && k < rig.bodies.size(); ++k) {
    if (rig.bodies[k].name == fault->body) return static_cast<int>(k);
  }
  throw UsageError(option + ": '" + fault->body + "' is not a body of the rig " + rig.path +
                   " (@BODY names one of its [[body]] tables, in a rig of several)");
}

// The assembly against the rig: the same bodies, by name and box, bottom-up
// (the rig's boxes place the LEDs and the pivots). A one-body assembly
// takes a single-block rig. Throws UsageError naming both files.
void CheckRigBodies(const daq::RigConfig& rig, const pipeline::Assembly& a) {
  const std::string where = "--assembly: " + a.path + " against the rig " + rig.path + ": ";
  if (a.frame) throw UsageError(where + "a [frame] has no bodies to put LEDs on; synth takes [[body]] stacks");
  if (a.bodies.size() == 1) {
    if (rig.multi_body()) {
      throw UsageError(where + "one body in the assembly, " + std::to_string(rig.bodies.size()) + " in the rig");
    }
    return;
  }
  if (rig.bodies.size() != a.bodies.size()) {
    throw UsageError(where + std::to_string(a.bodies.size()) + " bodies in the assembly, " +
                     std::to_string(rig.bodies.size()) + " [[body]] tables in the rig (the same, bottom-up)");
  }
  for (std::size_t k = 0; k < a.bodies.size(); ++k) {
    const daq::RigBody& r = rig.bodies[k];
    const pipeline::AssemblyBody& b = a.bodies[k];
    auto same = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(std::abs(x), std::abs(y)); };
    if (r.name != b.name || !same(r.width_m, b.width_m) || !same(r.height_m, b.height_m)) {
      throw UsageError(where + "body " + std::to_string(k + 1) + " is '" + b.name + "' " + std::to_string(b.width_m) +
                       " x " + std::to_string(b.height_m) + " m in the assembly, '" + r.name + "' " +
                       std::to_string(r.width_m) + " x " + std::to_string(r.height_m) + " m in the rig (line " +
                       std::to_string(r.line) + "): name, width_m and height_m must agree");
    }
  }
}

int RunSynth(const SynthOptions& o) {
  const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
  Require(std::abs(o.scenario.rate_hz - rig.sample_rate_hz) <= 1e-9 * rig.sample_rate_hz,
          "--rate", "the rig's sample_rate_hz (" + std::to_string(rig.sample_rate_hz) + " Hz)",
          o.scenario.rate_hz);
  Require(std::isfinite(o.noise_scale) && o.noise_scale >= 0, "--noise-scale", ">= 0", o.noise_scale);
  Require(o.occlusion >= 0 && o.occlusion < 1, "--occlusion", "in [0, 1)", o.occlusion);
  Require(o.drop >= 0 && o.drop < 1, "--drop", "in [0, 1)", o.drop);
  RequireOneStandardOutput({{"--out", o.out}, {"--truth", o.truth_csv}});
  RequireOutputFolder("--out", o.out);
  RequireOutputFolder("--truth", o.truth_csv);
  const std::optional<Fault> slip = ParseFault(o.slip_text, "--slip");
  const std::optional<Fault> twist = ParseFault(o.twist_text, "--twist");
  Require(std::isfinite(o.hold_s) && o.hold_s >= 0, "--hold", ">= 0 s", o.hold_s);
  const int slip_body = FaultBody(slip, rig, "--slip");
  // Without @BODY the bottom body: every pair reads the twist, as the one pair did.
  const int twist_body = FaultBody(twist, rig, "--twist");
  // The motion: a single block's run (the scenario), or an assembly's,
  // held whole (pipeline::RunAssembly) and sampled below.
  pipeline::Scenario scenario;
  std::optional<pipeline::AssemblyRun> assembly_run;
  std::unique_ptr<model::Forcing> assembly_forcing;
  if (o.assembly_toml.empty()) {
    if (rig.multi_body()) {
      throw UsageError("--rig: " + rig.path + " has " + std::to_string(rig.bodies.size()) +
                       " bodies: give their motion with --assembly FILE.toml");
    }
    scenario = pipeline::BuildScenario(o.scenario);
  } else {
    const pipeline::Assembly assembly = pipeline::ReadAssembly(InputFile("--assembly", o.assembly_toml, ".toml"));
    CheckRigBodies(rig, assembly);
    std::string description;
    assembly_forcing = pipeline::BuildForcing(o.scenario, description);
    assembly_run = pipeline::RunAssembly(assembly, o.scenario);
  }
  const model::Forcing& forcing = assembly_run ? *assembly_forcing : *scenario.forcing;
  const int bodies = assembly_run ? static_cast<int>(assembly_run->names.size()) : 1;

  daq::SimulatorNoise noise = daq::SimulatorNoise::Typical().Scaled(o.noise_scale);
  noise.occlusion = o.occlusion;
  noise.drop = o.drop;
  daq::RigSimulator sim(rig, noise, o.seed);
  // The raw file whole or not at all (an AtomicFile renamed at the end);
  // - : a CSV on standard output once it is complete.
  const auto format = daq::RawFileWriter::FormatOf(o.out);
  OutputTarget raw_target("--out", o.out, ".csv");
  std::unique_ptr<common::AtomicFile> raw_file;
  std::unique_ptr<daq::RawFileWriter> raw;
  try {
    raw_file = std::make_unique<common::AtomicFile>(raw_target.path());
    raw = std::make_unique<daq::RawFileWriter>(raw_file->path(), format, sim.channel_names(),
                                               rig.sample_rate_hz, o.decimal_comma);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--out: ") + e.what());
  }
  // The hold: whole samples before the scenario's t = 0, which then runs at
  // t + hold (the lab's free-rocking test: the block held, then let go).
  const int64_t hold_samples = static_cast<int64_t>(std::llround(o.hold_s * o.scenario.rate_hz));
  const double hold_s = static_cast<double>(hold_samples) / o.scenario.rate_hz;
  const int64_t run_samples =
      assembly_run ? static_cast<int64_t>(assembly_run->time_s.size())
                   : static_cast<int64_t>(std::floor(o.scenario.duration_s * o.scenario.rate_hz + 1e-9)) + 1;
  raw->StartSegment(0.0, hold_samples + run_samples);
  pipeline::OutputFile truth(o.truth_csv);
  std::FILE* tf = truth.get();
  if (bodies == 1) {
    std::fprintf(tf, "time,theta,theta_dot,table_displacement,table_acceleration,slip,twist,dropped\n");
  } else {
    std::fprintf(tf, "time");
    for (int k = 1; k <= bodies; ++k) std::fprintf(tf, ",theta_%d,theta_dot_%d", k, k);
    std::fprintf(tf, ",table_displacement,table_acceleration,slip,twist,dropped,mode\n");
  }

  model::TableMotion table(forcing);
  std::vector<double> values;
  long written = 0, dropped = 0;
  // One sample: the scenario's time, the bodies' angles and rates (one for
  // a single block), the contact mode (a stack's, "" otherwise).
  auto sample_bodies = [&](double t_scenario, const double* theta, const double* theta_dot, const char* mode) {
    const double t = t_scenario + hold_s;
    daq::TrueMotion m;
    m.time_s = t;
    m.theta = theta[0];
    for (int k = 0; k < bodies; ++k) m.body_theta[static_cast<std::size_t>(k)] = theta[k];
    if (t_scenario >= 0) table.At(t_scenario, m.table_displacement, m.table_acceleration);
    if (slip && t >= slip->time_s) m.slip_m = slip->size;
    m.slip_body = slip_body;
    if (twist && t >= twist->time_s) m.twist_rad = twist->size;
    m.twist_body = twist_body;
    const bool kept = sim.Raw(m, values);
    if (kept) {
      raw->Write(t, values);
      ++written;
    } else {
      ++dropped;
    }
    if (bodies == 1) {
      std::fprintf(tf, "%.9f,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d\n", t, m.theta, theta_dot[0],
                   m.table_displacement, m.table_acceleration, m.slip_m, m.twist_rad, kept ? 0 : 1);
      return;
    }
    std::fprintf(tf, "%.9f", t);
    for (int k = 0; k < bodies; ++k) std::fprintf(tf, ",%.17g,%.17g", theta[k], theta_dot[k]);
    std::fprintf(tf, ",%.17g,%.17g,%.17g,%.17g,%d,%s\n", m.table_displacement, m.table_acceleration, m.slip_m,
                 m.twist_rad, kept ? 0 : 1, mode);
  };
  auto sample = [&](double t_scenario, double theta, double theta_dot) {
    sample_bodies(t_scenario, &theta, &theta_dot, "");
  };
  std::array<double, daq::kMaxRigBodies> at_rest{};
  std::array<double, daq::kMaxRigBodies> held_theta{};
  held_theta.fill(o.scenario.theta0);  // a single block's --theta0; an assembly starts from rest (0)
  const std::string rest_mode(static_cast<std::size_t>(bodies), 'C');
  for (int64_t k = 0; k < hold_samples; ++k) {
    sample_bodies(static_cast<double>(k - hold_samples) / o.scenario.rate_hz, held_theta.data(), at_rest.data(),
                  rest_mode.c_str());
  }
  pipeline::RunSummary summary;
  if (!assembly_run) {
    summary = pipeline::RunScenario(scenario, o.scenario, sample);
  } else {
    const pipeline::AssemblyRun& r = *assembly_run;
    std::array<double, daq::kMaxRigBodies> theta{}, theta_dot{};
    for (std::size_t i = 0; i < r.time_s.size(); ++i) {
      for (std::size_t k = 0; k < r.names.size(); ++k) {
        theta[k] = r.theta[k][i];
        theta_dot[k] = r.theta_dot[k][i];
      }
      sample_bodies(r.time_s[i], theta.data(), theta_dot.data(), r.mode[i].c_str());
    }
    // The summary's figures over every body (the peak: the largest of any).
    const pipeline::AssemblySummary a = pipeline::Summarise(r);
    summary.uplift_time_s = a.uplift_time_s;
    summary.impacts = a.impacts;
    summary.overturned = a.overturn_time_s.has_value();
    for (std::size_t k = 0; k < a.peak_abs_theta.size(); ++k) {
      if (a.peak_abs_theta[k] > summary.peak_abs_theta) {
        summary.peak_abs_theta = a.peak_abs_theta[k];
        summary.peak_time_s = a.peak_time_s[k];
      }
    }
  }
  raw->Close();
  raw_file->Commit();
  truth.Close();
  raw_target.Finish();
  for (const std::string& written_file : {o.out, o.truth_csv}) {  // beside each: the files stay as readers expect
    common::WriteProvenanceSidecar(written_file, {o.rig_path, o.scenario.accel_csv, o.assembly_toml});
  }
  if (o.json) {
    auto optional = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); };
    nlohmann::json result = {
        {"out", o.out},
        {"truth", o.truth_csv},
        {"samples_written", written},
        {"samples_dropped", dropped},
        {"hold", hold_s},
        {"seed", o.seed},
        {"uplift_time", optional(summary.uplift_time_s)},
        {"peak_abs_theta", summary.peak_abs_theta},
        {"peak_time", summary.peak_time_s},
        {"impacts", summary.impacts},
        {"overturned", summary.overturned},
        {"units", {{"hold", "s"}, {"uplift_time", "s"}, {"peak_abs_theta", "rad"}, {"peak_time", "s"}}}};
    if (assembly_run) {
      result["assembly"] = o.assembly_toml;
      result["bodies"] = assembly_run->names;
    }
    WriteResult(result, true, "", o.truth_csv == "-" || o.out == "-");
  }
  std::fprintf(stderr, "%ld samples written to %s (%ld dropped), truth in %s; peak |theta| %.5f rad, %d impacts\n",
               written, raw_target.name().c_str(), dropped, o.truth_csv == "-" ? "standard output" : o.truth_csv.c_str(),
               summary.peak_abs_theta,
               summary.impacts);
  return 0;
}

}  // namespace

void RegisterSynth(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<SynthOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("synth", "rig simulator: a model run written as a raw channel file");
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML)")->required();
  pipeline::AddScenarioOptions(*cmd, opts->scenario, FormatsHelp(DataKind::kGroundMotion));
  cmd->add_option("--noise-scale", opts->noise_scale,
                  "multiplies the typical sensor noise (0.2 mm LEDs, 0.1 mm mirror spot, ...)")
      ->capture_default_str();
  cmd->add_option("--occlusion", opts->occlusion, "probability an LED is hidden at a sample")
      ->capture_default_str();
  cmd->add_option("--drop", opts->drop, "probability a sample is lost")->capture_default_str();
  cmd->add_option("--slip", opts->slip_text,
                  "pivot slip SIZE_M@TIME_S (a step); SIZE_M@TIME_S@BODY: that body's pivot on the one below "
                  "(--assembly)");
  cmd->add_option("--twist", opts->twist_text,
                  "twist RAD@TIME_S (a step); RAD@TIME_S@BODY: that body's twist, the bodies above turning with "
                  "it (--assembly)");
  cmd->add_option("--seed", opts->seed, "noise seed")->capture_default_str();
  cmd->add_option("--hold", opts->hold_s,
                  "s the block is held at --theta0 (table at rest) before the run starts (a free-rocking "
                  "test's release); the run's times follow it")
      ->capture_default_str();
  cmd->add_flag("--decimal-comma", opts->decimal_comma, "LVM output with a decimal comma");
  cmd->add_option("--out", opts->out, "raw file, RAW.csv or RAW.lvm (- : CSV on standard output)")->required();
  cmd->add_option("--truth", opts->truth_csv,
                  "truth CSV: time,theta,theta_dot,table_displacement,table_acceleration,slip,"
                  "twist,dropped (s, rad, rad/s, m, m/s^2, m, rad, 0/1)")
      ->required();
  AddJsonFlag(*cmd, opts->json);
  AddAssemblyOption(*cmd, opts->assembly_toml);
  cmd->callback([opts, cmd, &run] {
    run = [opts, cmd] {
      CheckAssemblyOptions(*cmd, opts->assembly_toml);
      opts->scenario.accel_csv = InputFile("--accel", opts->scenario.accel_csv);
      pipeline::ResolveDuration(*cmd, opts->scenario);
      return RunSynth(*opts);
    };
  });
}

}  // namespace rocklab::tools
