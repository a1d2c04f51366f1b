// rocklab synth: the rig simulator. Runs a model scenario (the options of
// `rocklab simulate`), turns the block's and the table's motion into raw
// channel values through the inverse measurement models of the rig
// (daq/rig_simulator.h) with seeded noise, LED occlusions, dropped samples
// and optional slip / twist faults, and writes the raw file and the truth.
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
#include "pipeline/pipeline.h"
#include "pipeline/scenario.h"
#include "pipeline/scenario_flags.h"
#include "tools/cli.h"
#include "tools/formats.h"

namespace rocklab::tools {
namespace {

struct Fault {
  double size{};    ///< m (slip) or rad (twist)
  double time_s{};  ///< s
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
};

// "SIZE@TIME" -> Fault; throws UsageError naming the option.
std::optional<Fault> ParseFault(const std::string& text, const std::string& option) {
  if (text.empty()) return std::nullopt;
  const size_t at = text.find('@');
  Fault f;
  try {
    if (at == std::string::npos) throw std::invalid_argument("no @");
    size_t used = 0;
    f.size = std::stod(text.substr(0, at), &used);
    if (used != at) throw std::invalid_argument("size");
    const std::string time = text.substr(at + 1);
    f.time_s = std::stod(time, &used);
    if (used != time.size()) throw std::invalid_argument("time");
  } catch (const std::exception&) {
    throw UsageError(option + " must be SIZE@TIME_S (e.g. 0.003@2.5), got '" + text + "'");
  }
  Require(std::isfinite(f.size), option, "a finite size", f.size);
  Require(std::isfinite(f.time_s) && f.time_s >= 0, option, "a time >= 0 s", f.time_s);
  return f;
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
  pipeline::Scenario scenario = pipeline::BuildScenario(o.scenario);

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
  raw->StartSegment(0.0, hold_samples +
                             static_cast<int64_t>(std::floor(o.scenario.duration_s * o.scenario.rate_hz + 1e-9)) + 1);
  pipeline::OutputFile truth(o.truth_csv);
  std::FILE* tf = truth.get();
  std::fprintf(tf, "time,theta,theta_dot,table_displacement,table_acceleration,slip,twist,dropped\n");

  model::TableMotion table(*scenario.forcing);
  std::vector<double> values;
  long written = 0, dropped = 0;
  auto sample = [&](double t_scenario, double theta, double theta_dot) {
    const double t = t_scenario + hold_s;
    daq::TrueMotion m;
    m.time_s = t;
    m.theta = theta;
    if (t_scenario >= 0) table.At(t_scenario, m.table_displacement, m.table_acceleration);
    if (slip && t >= slip->time_s) m.slip_m = slip->size;
    if (twist && t >= twist->time_s) m.twist_rad = twist->size;
    const bool kept = sim.Raw(m, values);
    if (kept) {
      raw->Write(t, values);
      ++written;
    } else {
      ++dropped;
    }
    std::fprintf(tf, "%.9f,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d\n", t, m.theta, theta_dot,
                 m.table_displacement, m.table_acceleration, m.slip_m, m.twist_rad, kept ? 0 : 1);
  };
  for (int64_t k = 0; k < hold_samples; ++k) {
    sample(static_cast<double>(k - hold_samples) / o.scenario.rate_hz, o.scenario.theta0, 0.0);
  }
  const pipeline::RunSummary summary = pipeline::RunScenario(scenario, o.scenario, sample);
  raw->Close();
  raw_file->Commit();
  truth.Close();
  raw_target.Finish();
  for (const std::string& written_file : {o.out, o.truth_csv}) {  // beside each: the files stay as readers expect
    common::WriteProvenanceSidecar(written_file, {o.rig_path, o.scenario.accel_csv});
  }
  if (o.json) {
    auto optional = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); };
    const nlohmann::json result = {
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
  cmd->add_option("--slip", opts->slip_text, "pivot slip SIZE_M@TIME_S (a step)");
  cmd->add_option("--twist", opts->twist_text, "twist RAD@TIME_S (a step)");
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
  cmd->callback([opts, cmd, &run] {
    run = [opts, cmd] {
      opts->scenario.accel_csv = InputFile("--accel", opts->scenario.accel_csv);
      pipeline::ResolveDuration(*cmd, opts->scenario);
      return RunSynth(*opts);
    };
  });
}

}  // namespace rocklab::tools
