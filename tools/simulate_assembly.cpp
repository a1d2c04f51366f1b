// `rocklab simulate --assembly FILE.toml`: the run of pipeline/assembly.h
// as CSV (one theta and theta_dot column per body, then the mode), its
// events naming interface and body, and the summary.
#include "tools/simulate_assembly.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>

#include <CLI/CLI.hpp>

#include "common/csv_number.h"
#include "common/provenance.h"
#include "common/units.h"
#include "pipeline/assembly.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

// The single block's options that an assembly file replaces.
constexpr const char* kBlockOnlyOptions[] = {"--alpha", "--p", "--mu", "--theta0"};

// Appends `v` as the shortest text that reads back as the same double (the
// CSV keeps the solution to the last bit, as simulate's).
void AppendShortest(std::string& line, double v) {
  char text[48];
  line.append(text, common::csv_number::WriteShortest(v, text));
}

void WriteAssemblyCsv(const pipeline::AssemblyRun& run, const std::string& path) {
  pipeline::OutputFile out(path);
  std::string text = "time";
  for (std::size_t k = 1; k <= run.names.size(); ++k) {
    text += ",theta_" + std::to_string(k) + ",theta_dot_" + std::to_string(k);
  }
  text += ",mode\n";
  for (std::size_t i = 0; i < run.time_s.size(); ++i) {
    AppendShortest(text, run.time_s[i]);
    for (std::size_t k = 0; k < run.names.size(); ++k) {
      text += ',';
      AppendShortest(text, run.theta[k][i]);
      text += ',';
      AppendShortest(text, run.theta_dot[k][i]);
    }
    text += ',';
    text += run.mode[i];
    text += '\n';
    if (text.size() > (1u << 16)) {
      std::fwrite(text.data(), 1, text.size(), out.get());
      text.clear();
    }
  }
  std::fwrite(text.data(), 1, text.size(), out.get());
  out.Close();
}

void WriteAssemblyEventsCsv(const pipeline::AssemblyRun& run, const std::string& path) {
  pipeline::OutputFile out(path);
  std::fprintf(out.get(), "time,kind,interface,body,mode\n");
  for (const pipeline::AssemblyEvent& e : run.events) {
    std::fprintf(out.get(), "%.9f,%s,%d,%s,%s\n", e.time_s, model::ToString(e.kind), e.interface,
                 run.names[static_cast<std::size_t>(e.interface)].c_str(), e.mode.c_str());
  }
  out.Close();
}

void PrintAssemblySummary(std::FILE* report, const pipeline::ScenarioOptions& o, const std::string& path,
                          const pipeline::AssemblyRun& run, const pipeline::AssemblySummary& s,
                          const std::string& written_to) {
  std::fprintf(report, "%s %s (%zu bod%s), %s model", run.kind.c_str(), path.c_str(), run.names.size(),
               run.names.size() == 1 ? "y" : "ies", o.model.c_str());
  if (run.block) {
    std::fprintf(report, ", alpha %.4f rad, p %.4f rad/s, mu %.4f", run.block->alpha, run.block->p, run.block->mu);
  }
  std::fprintf(report, "; excitation %s\n", run.forcing_description.c_str());
  if (s.uplift_time_s) {
    std::fprintf(report, "  uplift at %.4f s\n", *s.uplift_time_s);
  } else {
    std::fprintf(report, "  no uplift\n");
  }
  for (std::size_t k = 0; k < run.names.size(); ++k) {
    std::fprintf(report, "  %s: peak |theta| %.5f rad (%.3f deg) at %.4f s\n", run.names[k].c_str(),
                 s.peak_abs_theta[k], s.peak_abs_theta[k] * common::kDegPerRad, s.peak_time_s[k]);
  }
  std::fprintf(report, "  %d impacts, %zu modes, %d mode changes", s.impacts, s.modes.size(), s.mode_changes);
  if (s.overturn_time_s) {
    std::fprintf(report, ", OVERTURNED: %s at %.4f s", s.overturned_body.c_str(), *s.overturn_time_s);
  }
  std::fprintf(report, "\n");
  if (run.impacts_preload > 0 || run.impacts_held_pivots > 0) {
    std::fprintf(report, "  of the impacts, %d resolved within the contacts' preloads, %d with pivots held\n",
                 run.impacts_preload, run.impacts_held_pivots);
  }
  std::fprintf(report, "  %zu rows written to %s\n", run.time_s.size(), written_to.c_str());
}

}  // namespace

void AddAssemblyOption(CLI::App& cmd, std::string& path) {
  CLI::Option* assembly = cmd.add_option(
      "--assembly", path,
      "an assembly of bodies instead of --alpha/--p/--mu: a TOML file of [[body]] tables bottom-up "
      "(name, width_m, height_m, mass_kg or depth_m and density_kg_m3) with optional [[interface]] "
      "restitution, or a [frame] (docs/commands.md)");
  for (const char* name : kBlockOnlyOptions) {
    CLI::Option* block = cmd.get_option(name);
    if (block->get_required()) {
      block->required(false);
      block->description(block->get_description() + " (required without --assembly)");
      RequiredUnless(block, assembly);
    }
    assembly->excludes(block);
  }
}

void CheckAssemblyOptions(const CLI::App& cmd, const std::string& path) {
  if (!path.empty()) return;  // CLI11 refused the block's options beside it
  CheckRequiredUnless(cmd);
}

int RunSimulateAssembly(const pipeline::ScenarioOptions& o, const std::string& path, const std::string& out_csv,
                        const std::string& events_csv, bool json) {
  RequireOneStandardOutput({{"--out", out_csv}, {"--events", events_csv}});
  const pipeline::Assembly assembly = pipeline::ReadAssembly(InputFile("--assembly", path, ".toml"));
  const std::clock_t cpu0 = std::clock();
  const pipeline::AssemblyRun run = pipeline::RunAssembly(assembly, o);
  const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  WriteAssemblyCsv(run, out_csv);
  if (!events_csv.empty()) WriteAssemblyEventsCsv(run, events_csv);
  for (const std::string& csv : {out_csv, events_csv}) common::WriteProvenanceSidecar(csv, {path, o.accel_csv});

  if (run.impacts_held_pivots > 0) {  // a block that would have jumped was kept on its pivot
    std::fprintf(stderr,
                 "simulate: warning: %s: %d impact%s resolved only with pivots held (a block that would jump kept "
                 "on its pivot; docs/models.md, \"Impacts: the contact states after\")\n",
                 path.c_str(), run.impacts_held_pivots, run.impacts_held_pivots == 1 ? "" : "s");
  }
  const pipeline::AssemblySummary s = pipeline::Summarise(run);
  std::FILE* report = out_csv == "-" || events_csv == "-" ? stderr : stdout;
  if (json) {
    std::fprintf(report, "%s\n", pipeline::AssemblySummaryJson(o, path, run, s, cpu_s).c_str());
  } else {
    PrintAssemblySummary(report, o, path, run, s, out_csv == "-" ? "standard output" : out_csv);
  }
  return 0;
}

}  // namespace rocklab::tools
