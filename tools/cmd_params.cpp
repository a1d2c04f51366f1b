// rocklab params: alpha, p and mu of a block from its geometry (Table 1).
#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "model/block.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct ParamsOptions {
  double width_m{};
  double height_m{};
  double chamfer_m{};
  bool json{};
};

int RunParams(const ParamsOptions& o) {
  Require(std::isfinite(o.width_m) && o.width_m > 0, "--width", "> 0 m", o.width_m);
  Require(std::isfinite(o.height_m) && o.height_m > 0, "--height", "> 0 m", o.height_m);
  Require(std::isfinite(o.chamfer_m) && o.chamfer_m >= 0 &&
              o.chamfer_m < 0.5 * std::min(o.width_m, o.height_m),
          "--chamfer", ">= 0 m and below half the width and half the height", o.chamfer_m);
  const model::BlockGeometry g = model::RectangleBlock(o.width_m, o.height_m, o.chamfer_m);
  if (o.json) {
    nlohmann::json j = {
        {"width", o.width_m},         {"height", o.height_m},
        {"chamfer", o.chamfer_m},     {"alpha", g.alpha},
        {"p", g.p},                   {"mu", g.mu_general},
        {"mu_housner", g.mu_housner}, {"mu_general", g.mu_general},
        {"R", g.R},                   {"I_O_per_mass", g.i_o_per_area},
        {"g", model::kGravity},
        {"units", {{"width", "m"}, {"height", "m"}, {"chamfer", "m"}, {"alpha", "rad"},
                   {"p", "rad/s"}, {"mu", "1"}, {"R", "m"}, {"I_O_per_mass", "m^2"},
                   {"g", "m/s^2"}}}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("block 2b x 2h = %.4g m x %.4g m, base chamfer %.4g m\n", o.width_m, o.height_m,
              o.chamfer_m);
  std::printf("  alpha        %.4f rad\n", g.alpha);
  std::printf("  p            %.4f rad/s\n", g.p);
  std::printf("  mu           %.4f        (1 - (2 M R^2 / I_O) sin^2 alpha)\n", g.mu_general);
  std::printf("  mu_housner   %.4f        (1 - 1.5 sin^2 alpha, eq. 11)\n", g.mu_housner);
  std::printf("  R            %.4f m\n", g.R);
  std::printf("  I_O / M      %.6f m^2\n", g.i_o_per_area);
  return 0;
}

}  // namespace

void RegisterParams(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<ParamsOptions>();  // shared: outlives this call, owned by the callback
  CLI::App* cmd = app.add_subcommand("params", "alpha, p and mu of a block from its geometry");
  cmd->add_option("--width", opts->width_m, "block width 2b, m")->required();
  cmd->add_option("--height", opts->height_m, "block height 2h, m")->required();
  cmd->add_option("--chamfer", opts->chamfer_m,
                  "45 degree chamfer leg on both base corners, m")->capture_default_str();
  cmd->add_flag("--json", opts->json, "print JSON");
  cmd->callback([opts, &run] { run = [opts] { return RunParams(*opts); }; });
}

}  // namespace rocklab::tools
