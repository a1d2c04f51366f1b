// rocklab params: alpha, p and mu of a block from its geometry (Table 1): a
// rectangle with optional base chamfers, or any polygon section from a CSV
// file (per side: an asymmetric section rocks differently on its two pivots).
#include <algorithm>
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
  std::string polygon;
  bool json{};
};

nlohmann::json SideJson(const model::SideGeometry& s) {
  return {{"alpha", s.alpha}, {"R", s.R}, {"p", s.p}, {"mu", s.mu}, {"I_O_per_mass", s.i_o_per_area},
          {"pivot", {s.pivot_m.x(), s.pivot_m.y()}}};
}

void PrintSide(const char* name, const model::SideGeometry& s) {
  std::printf("  %-6s pivot (%.4g, %.4g) m: alpha %.4f rad, R %.4f m, p %.4f rad/s, mu %.4f, I_O/M %.6f m^2\n",
              name, s.pivot_m.x(), s.pivot_m.y(), s.alpha, s.R, s.p, s.mu, s.i_o_per_area);
}

int RunParams(const ParamsOptions& o) {
  model::BlockGeometry g;
  double width_m = o.width_m;
  double height_m = o.height_m;
  std::size_t n_vertices = 0;
  if (!o.polygon.empty()) {
    if (o.width_m != 0.0 || o.height_m != 0.0 || o.chamfer_m != 0.0) {
      throw UsageError("give either --polygon or --width/--height/--chamfer, not both");
    }
    model::PolygonFile file;
    try {
      file = model::ReadPolygonCsv(InputFile("--polygon", o.polygon));
      g = model::PolygonBlock(file);
    } catch (const std::invalid_argument& e) {
      throw UsageError(e.what());
    }
    n_vertices = file.vertices_m.size();
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, z0 = HUGE_VAL, z1 = -HUGE_VAL;
    for (const auto& v : file.vertices_m) {
      x0 = std::min(x0, v.x());
      x1 = std::max(x1, v.x());
      z0 = std::min(z0, v.y());
      z1 = std::max(z1, v.y());
    }
    width_m = x1 - x0;
    height_m = z1 - z0;
  } else {
    if (o.width_m == 0.0 && o.height_m == 0.0) {
      throw UsageError("--width and --height are required (or --polygon FILE.csv)");
    }
    Require(std::isfinite(o.width_m) && o.width_m > 0, "--width", "> 0 m", o.width_m);
    Require(std::isfinite(o.height_m) && o.height_m > 0, "--height", "> 0 m", o.height_m);
    Require(std::isfinite(o.chamfer_m) && o.chamfer_m >= 0 &&
                o.chamfer_m < 0.5 * std::min(o.width_m, o.height_m),
            "--chamfer", ">= 0 m and below half the width and half the height", o.chamfer_m);
    g = model::RectangleBlock(o.width_m, o.height_m, o.chamfer_m);
  }
  const bool polygon = !o.polygon.empty();
  if (o.json) {
    nlohmann::json j = {
        {"width", width_m},           {"height", height_m},
        {"chamfer", polygon ? nlohmann::json(nullptr) : nlohmann::json(o.chamfer_m)},
        {"alpha", g.alpha},           {"p", g.p},
        {"mu", g.mu_general},         {"mu_housner", g.mu_housner},
        {"mu_general", g.mu_general}, {"R", g.R},
        {"I_O_per_mass", g.i_o_per_area},
        {"g", model::kGravity},
        {"polygon", polygon ? nlohmann::json(o.polygon) : nlohmann::json(nullptr)},
        {"vertices", polygon ? nlohmann::json(n_vertices) : nlohmann::json(nullptr)},
        {"area", g.area},
        {"I_G_per_mass", g.i_g_per_area},
        {"centroid", {g.centroid_m.x(), g.centroid_m.y()}},
        {"symmetric", g.symmetric},
        {"plus_side", SideJson(g.plus)},
        {"minus_side", SideJson(g.minus)},
        {"units", {{"width", "m"}, {"height", "m"}, {"chamfer", "m"}, {"alpha", "rad"},
                   {"p", "rad/s"}, {"mu", "1"}, {"R", "m"}, {"I_O_per_mass", "m^2"},
                   {"I_G_per_mass", "m^2"}, {"area", "m^2"}, {"centroid", "m"}, {"pivot", "m"},
                   {"g", "m/s^2"}}}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  if (polygon) {
    std::printf("polygon %s: %zu vertices, %.4g m x %.4g m, area %.6g m^2, %s\n", o.polygon.c_str(),
                n_vertices, width_m, height_m, g.area, g.symmetric ? "symmetric" : "asymmetric");
  } else {
    std::printf("block 2b x 2h = %.4g m x %.4g m, base chamfer %.4g m\n", o.width_m, o.height_m,
                o.chamfer_m);
  }
  std::printf("  alpha        %.4f rad\n", g.alpha);
  std::printf("  p            %.4f rad/s\n", g.p);
  std::printf("  mu           %.4f        (%s)\n", g.mu_general,
              g.symmetric ? "1 - (2 M R^2 / I_O) sin^2 alpha"
                          : "impact onto the +x pivot: (I_G + M r_+ . r_-) / I_O+");
  std::printf("  mu_housner   %.4f        (1 - 1.5 sin^2 alpha, eq. 11)\n", g.mu_housner);
  std::printf("  R            %.4f m\n", g.R);
  std::printf("  I_O / M      %.6f m^2\n", g.i_o_per_area);
  if (polygon || !g.symmetric) {
    std::printf("per side (theta > 0 rocks on +x, theta < 0 on -x; mu: impact landing on that pivot):\n");
    PrintSide("+x", g.plus);
    PrintSide("-x", g.minus);
  }
  return 0;
}

}  // namespace

void RegisterParams(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<ParamsOptions>();  // shared: outlives this call, owned by the callback
  CLI::App* cmd = app.add_subcommand("params", "alpha, p and mu of a block from its geometry");
  cmd->add_option("--width", opts->width_m, "block width 2b, m");
  cmd->add_option("--height", opts->height_m, "block height 2h, m");
  cmd->add_option("--chamfer", opts->chamfer_m,
                  "45 degree chamfer leg on both base corners, m")->capture_default_str();
  cmd->add_option("--polygon", opts->polygon,
                  "section as a CSV of vertices, header x,z (m), in order, standing on its base edge");
  cmd->add_flag("--json", opts->json, "print JSON");
  cmd->callback([opts, &run] { run = [opts] { return RunParams(*opts); }; });
}

}  // namespace rocklab::tools
