// rocklab simulate: one model on one scenario, written as CSV.
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "common/csv_number.h"
#include "common/provenance.h"
#include "common/units.h"
#include "pipeline/scenario.h"
#include "pipeline/scenario_flags.h"
#include "tools/cli.h"
#include "tools/formats.h"
#include "tools/simulate_assembly.h"

namespace rocklab::tools {
namespace {

struct SimulateOptions {
  pipeline::ScenarioOptions scenario;
  std::string out_csv;
  std::string events_csv;
  bool json{};
  std::string assembly_toml;  ///< --assembly: an assembly instead of the block (tools/simulate_assembly.h)
};

// The output rows, formatted into a buffer written in blocks: each number the
// shortest text that reads back as the same double (std::to_chars' bytes,
// from common/csv_number.h's WriteShortest), so the
// CSV holds the solution to the last bit, at a fraction of printf's cost
// (which was most of simulate's time after the solve, docs/performance.md).
class RowWriter {
 public:
  explicit RowWriter(std::FILE* out) : out_(out) {}
  ~RowWriter() { Flush(); }
  RowWriter(const RowWriter&) = delete;
  RowWriter& operator=(const RowWriter&) = delete;
  void Row(double t_s, double theta, double theta_dot) {
    if (kBuffer - used_ < kMaxRow) Flush();
    Put(t_s);
    buffer_[used_++] = ',';
    Put(theta);
    buffer_[used_++] = ',';
    Put(theta_dot);
    buffer_[used_++] = '\n';
  }
  /// Writes the buffered rows (before the file is closed).
  void Flush() {
    if (used_ > 0) std::fwrite(buffer_.data(), 1, used_, out_);
    used_ = 0;
  }

 private:
  static constexpr std::size_t kBuffer = 1 << 16;
  // Shortest round-trip text of a double: at most 24 characters
  // ("-1.2345678901234567e-308"); Shortest wants 48 bytes of room.
  static constexpr std::size_t kMaxRow = 3 * 25 + 48;
  void Put(double v) {
    used_ = static_cast<std::size_t>(common::csv_number::WriteShortest(v, &buffer_[used_]) - buffer_.data());
  }
  std::FILE* out_;
  std::array<char, kBuffer> buffer_{};
  std::size_t used_{0};
};

nlohmann::json SummaryJson(const pipeline::ScenarioOptions& o, const pipeline::Scenario& s, const pipeline::RunSummary& r,
                           double cpu_s) {
  const model::SolverStats stats = s.model->solver_stats();
  auto optional = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  return {{"model", o.model},
          {"alpha", o.alpha},
          {"p", o.p},
          {"mu", o.mu},
          {"l", o.model == "complex" ? nlohmann::json(o.l) : nlohmann::json(nullptr)},
          {"theta0", o.theta0},
          {"excitation", s.forcing_description},
          {"duration", o.duration_s},
          {"rate", o.rate_hz},
          {"samples", r.samples},
          {"uplift_time", optional(r.uplift_time_s)},
          {"peak_abs_theta", r.peak_abs_theta},
          {"peak_time", r.peak_time_s},
          {"impacts", r.impacts},
          {"overturned", r.overturned},
          {"overturn_time", optional(r.overturn_time_s)},
          {"final_regime", model::ToString(s.model->state().regime)},
          {"complex_handoff", o.model == "complex" ? nlohmann::json(o.complex_handoff) : nlohmann::json(nullptr)},
          {"eq10_fraction", stats.eq10_fraction},
          {"rocking_time", stats.rocking_time_s},
          {"steps", stats.steps},
          {"rhs_evals", stats.rhs_evals},
          {"error_test_fails", stats.error_test_fails},
          {"restarts", stats.restarts},
          {"recoveries", stats.recoveries},
          {"cpu_time", cpu_s},
          {"units", {{"alpha", "rad"}, {"p", "rad/s"}, {"theta0", "rad"}, {"duration", "s"},
                     {"rate", "Hz"}, {"uplift_time", "s"}, {"peak_abs_theta", "rad"},
                     {"peak_time", "s"}, {"overturn_time", "s"}, {"rocking_time", "s"}, {"cpu_time", "s"}}}};
}

int RunSimulate(const SimulateOptions& o) {
  if (o.out_csv == "-" && o.events_csv == "-") {
    throw UsageError("--out - and --events -: only one of them can be standard output");
  }
  pipeline::Scenario s = pipeline::BuildScenario(o.scenario);
  pipeline::OutputFile out(o.out_csv);
  std::FILE* f = out.get();
  std::fprintf(f, "time,theta,theta_dot\n");
  const std::clock_t cpu0 = std::clock();
  pipeline::RunSummary r;
  {
    RowWriter rows(f);
    r = pipeline::RunScenario(s, o.scenario, [&rows](double t, double theta, double theta_dot) {
      rows.Row(t, theta, theta_dot);
    });
  }
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  out.Close();
  if (!o.events_csv.empty()) pipeline::WriteEventsCsv(o.events_csv, s.model->events());
  // What made them, beside each (STEM.provenance.csv): the CSVs stay as their readers expect.
  for (const std::string& csv : {o.out_csv, o.events_csv}) common::WriteProvenanceSidecar(csv, {o.scenario.accel_csv});

  // With the CSV on standard output (--out -), the summary goes to stderr.
  std::FILE* report = o.out_csv == "-" || o.events_csv == "-" ? stderr : stdout;
  const std::string written_to = o.out_csv == "-" ? "standard output" : o.out_csv;
  if (o.json) {
    std::fprintf(report, "%s\n", SummaryJson(o.scenario, s, r, cpu_s).dump(2).c_str());
  } else {
    std::fprintf(report, "%s model, alpha %.4f rad, p %.4f rad/s, mu %.4f; excitation %s\n",
                o.scenario.model.c_str(), o.scenario.alpha, o.scenario.p, o.scenario.mu,
                s.forcing_description.c_str());
    if (r.uplift_time_s) {
      std::fprintf(report, "  uplift at %.4f s\n", *r.uplift_time_s);
    } else if (o.scenario.theta0 == 0.0) {
      std::fprintf(report, "  no uplift\n");
    }
    std::fprintf(report, "  peak |theta| %.5f rad (%.3f deg) at %.4f s, %d impacts%s\n",
                r.peak_abs_theta, r.peak_abs_theta * common::kDegPerRad, r.peak_time_s, r.impacts,
                r.overturned ? ", OVERTURNED" : "");
    if (s.model->kind() == model::ModelKind::kComplex) {
      const model::SolverStats stats = s.model->solver_stats();
      std::fprintf(report, "  eq. (10) for %.1f %% of the rocking time%s\n", 100.0 * stats.eq10_fraction,
                  o.scenario.complex_handoff > 0 ? " (l -> 0 hand-off on)" : "");
    }
    std::fprintf(report, "  %zu rows written to %s\n", r.samples, written_to.c_str());
  }
  return 0;
}

}  // namespace

void RegisterSimulate(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<SimulateOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("simulate", "simulate a rocking block (housner or complex)");
  pipeline::AddScenarioOptions(*cmd, opts->scenario, FormatsHelp(DataKind::kGroundMotion));
  cmd->add_option("--out", opts->out_csv, "output CSV: time,theta,theta_dot (s, rad, rad/s); - for standard output")
      ->required();
  cmd->add_option("--events", opts->events_csv, "events CSV: time,kind (s, name)");
  cmd->add_flag("--json", opts->json, "print the run summary as JSON");
  AddAssemblyOption(*cmd, opts->assembly_toml);
  cmd->callback([opts, cmd, &run] {
    run = [opts, cmd] {
      CheckAssemblyOptions(*cmd, opts->assembly_toml);
      opts->scenario.accel_csv = InputFile("--accel", opts->scenario.accel_csv);
      pipeline::ResolveDuration(*cmd, opts->scenario);
      if (!opts->assembly_toml.empty()) {
        return RunSimulateAssembly(opts->scenario, opts->assembly_toml, opts->out_csv, opts->events_csv, opts->json);
      }
      return RunSimulate(*opts);
    };
  });
}

}  // namespace rocklab::tools
