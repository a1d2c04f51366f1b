// rocklab demo: the paper's figure 7 scenario with both models, as a table.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "common/provenance.h"
#include "common/units.h"
#include "pipeline/scenario.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct DemoOptions {
  std::string out_dir{"demo"};
  bool json{};
};

int RunDemo(const DemoOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) throw UsageError("--out-dir: cannot create '" + o.out_dir + "': " + ec.message());

  // Figure 7: block 1 with Table 2's fitted parameters under a Hanning-windowed
  // sine of 6 mm at 3.3 Hz (docs/errata.md items 10 and 11; the paper gives no window
  // length: 4 s starting at 0.5 s).
  pipeline::ScenarioOptions base;
  base.alpha = 0.235;
  base.p = 3.884;
  base.mu = 0.937;
  base.excitations = {"hanning:amp=0.006,freq=3.3,duration=4,start=0.5"};
  base.duration_s = 8.0;
  base.rate_hz = 200.0;

  // The text goes to stdout, or with --json to nowhere (the JSON holds it).
  std::FILE* text = o.json ? nullptr : stdout;
  auto print = [text](const char* format, auto... args) {
    if (text != nullptr) std::fprintf(text, format, args...);
  };
  print("figure 7 scenario: block 1, alpha %.3f rad, p %.3f rad/s, mu %.3f\n", base.alpha, base.p, base.mu);
  print("table motion: %s (amp m, freq Hz, duration s, start s)\n\n", base.excitations.front().c_str());
  print("%-8s  %10s  %14s  %8s  %7s  %-10s  %s\n", "model", "uplift_s", "peak_theta_deg", "peak_s", "impacts",
        "final", "trajectory");
  nlohmann::json models = nlohmann::json::array();
  for (const char* name : {"housner", "complex"}) {
    pipeline::ScenarioOptions so = base;
    so.model = name;
    pipeline::Scenario s = pipeline::BuildScenario(so);
    const std::string path = (std::filesystem::path(o.out_dir) / (std::string(name) + ".csv")).string();
    pipeline::OutputFile out(path);
    std::FILE* f = out.get();
    std::fprintf(f, "time,theta,theta_dot\n");
    const pipeline::RunSummary r = pipeline::RunScenario(s, so, [f](double t, double theta, double theta_dot) {
      std::fprintf(f, "%.9g,%.12g,%.12g\n", t, theta, theta_dot);
    });
    out.Close();
    // Beside it, as simulate's: no input files (the scenario is built in),
    // so the scenario itself says what made it.
    auto fields = common::ProvenanceFields(common::MakeProvenance({}));
    char scenario[160];
    std::snprintf(scenario, sizeof scenario, "figure 7, model %s, alpha %.3f rad, p %.3f rad/s, mu %.3f, %s, %g s at %g Hz",
                  name, base.alpha, base.p, base.mu, base.excitations.front().c_str(), base.duration_s, base.rate_hz);
    fields.emplace_back("scenario", scenario);
    common::WriteProvenanceSidecarFields(path, fields);
    char uplift[32] = "none";
    if (r.uplift_time_s) std::snprintf(uplift, sizeof uplift, "%.4f", *r.uplift_time_s);
    print("%-8s  %10s  %14.4f  %8.3f  %7d  %-10s  %s\n", name, uplift, r.peak_abs_theta * common::kDegPerRad,
          r.peak_time_s, r.impacts, model::ToString(s.model->state().regime), path.c_str());
    models.push_back({{"model", name},
                      {"uplift_time", r.uplift_time_s ? nlohmann::json(*r.uplift_time_s) : nlohmann::json(nullptr)},
                      {"peak_abs_theta", r.peak_abs_theta},
                      {"peak_time", r.peak_time_s},
                      {"impacts", r.impacts},
                      {"final_regime", model::ToString(s.model->state().regime)},
                      {"trajectory", path}});
  }
  if (o.json) {
    WriteResult({{"alpha", base.alpha},
                 {"p", base.p},
                 {"mu", base.mu},
                 {"excitation", base.excitations.front()},
                 {"duration", base.duration_s},
                 {"rate", base.rate_hz},
                 {"models", models},
                 {"units",
                  {{"alpha", "rad"}, {"p", "rad/s"}, {"duration", "s"}, {"rate", "Hz"}, {"uplift_time", "s"},
                   {"peak_abs_theta", "rad"}, {"peak_time", "s"}}}},
                true);
  }
  return 0;
}

}  // namespace

void RegisterDemo(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<DemoOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("demo", "the paper's figure 7 scenario with both models");
  cmd->add_option("--out-dir", opts->out_dir, "folder for the trajectories (each with its provenance beside it, NAME.provenance.csv)")->capture_default_str();
  AddJsonFlag(*cmd, opts->json);
  cmd->callback([opts, &run] { run = [opts] { return RunDemo(*opts); }; });
}

}  // namespace rocklab::tools
