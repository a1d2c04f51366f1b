// rocklab info on the files that are neither LCM logs nor raw channel
// files: ground-motion records (time,accel CSV, PEER .AT2) and a sweep's
// results (CSV, HDF5): tools/formats.h's kinds. cmd_info.cpp dispatches
// here first.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/text.h"
#include "common/units.h"
#include "export/info.h"
#include "model/excitation.h"
#include "sweep/plot.h"
#include "sweep/results_h5.h"
#include "sweep/sweep.h"
#include "tools/cli.h"
#include "tools/formats.h"

namespace rocklab::tools {
namespace {

// The first line that is not blank or a '#' comment, trimmed, from the
// file's first 64 KiB (a binary or newline-free file is not read whole).
std::string FirstLine(const std::string& path) {
  constexpr std::size_t kMaxBytes = 64 * 1024;
  std::ifstream in(path, std::ios::binary);
  std::string head(kMaxBytes, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  std::size_t from = 0;
  while (from < head.size()) {
    const std::size_t end = std::min(head.find('\n', from), head.size());
    const std::string_view t = common::Trim(std::string_view(head).substr(from, end - from));
    if (!t.empty() && t.front() != '#') return std::string(t);
    from = end + 1;
  }
  return "";
}

// A header holding every column sweep-plot needs, in any order (as
// sweep::ReadResults accepts it).
bool IsSweepHeader(const std::string& header) {
  std::set<std::string> names;
  std::vector<std::string_view> fields;
  common::Split(header, ',', fields);
  for (std::string_view f : fields) names.emplace(common::Trim(f));
  for (const char* name : {"record", "scale", "pga_g", "alpha", "p", "mu", "model", "peak_theta_over_alpha",
                           "overturned"}) {
    if (names.count(name) == 0) return false;
  }
  return true;
}

std::string Fixed(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string GroundMotion(const std::string& path, const char* format, bool json) {
  const model::AccelerationRows rows = model::ReadAccelerationRows(path);
  const std::size_t n = rows.time_s.size();
  std::size_t at = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (std::abs(rows.accel_mps2[i]) > std::abs(rows.accel_mps2[at])) at = i;
  }
  const double pga = std::abs(rows.accel_mps2[at]);
  const double dt = (rows.time_s.back() - rows.time_s.front()) / static_cast<double>(n - 1);
  if (json) {
    const nlohmann::json j = {{"file", path},
                              {"kind", "ground_motion"},
                              {"format", format},
                              {"samples", n},
                              {"start", rows.time_s.front()},
                              {"end", rows.time_s.back()},
                              {"mean_dt", dt},
                              {"pga", pga},
                              {"pga_g", pga / common::kGravity},
                              {"pga_time", rows.time_s[at]},
                              {"units", {{"start", "s"}, {"end", "s"}, {"mean_dt", "s"}, {"pga", "m/s^2"},
                                         {"pga_g", "g"}, {"pga_time", "s"}}}};
    return exporter::JsonText(j, 2) + "\n";
  }
  return path + ": ground-motion record (" + format + ")\n  " + std::to_string(n) + " samples from " +
         Fixed("%.6g", rows.time_s.front()) + " to " + Fixed("%.6g", rows.time_s.back()) + " s, mean step " +
         Fixed("%.6g", dt) + " s\n  PGA " + Fixed("%.6g", pga) + " m/s^2 (" + Fixed("%.4g", pga / common::kGravity) +
         " g) at " + Fixed("%.6g", rows.time_s[at]) + " s\n"
         "  (rocklab simulate --accel, sweep --records, synth --accel and fit --accel read it)\n";
}

std::string SweepResults(const std::string& path, const char* format, bool json) {
  const std::vector<sweep::ResultRow> rows = sweep::ReadResults(path);
  std::vector<std::string> records;
  std::set<std::string> blocks, models;
  std::size_t overturned = 0;
  double pga_min = INFINITY, pga_max = 0;
  for (const sweep::ResultRow& r : rows) {
    if (std::find(records.begin(), records.end(), r.record) == records.end()) records.push_back(r.record);
    blocks.insert(r.model + "," + r.alpha_text + "," + r.p_text + "," + r.mu_text);
    models.insert(r.model);
    overturned += r.overturned ? 1 : 0;
    pga_min = std::min(pga_min, r.pga_g);
    pga_max = std::max(pga_max, r.pga_g);
  }
  const bool any = !rows.empty();
  if (json) {
    const nlohmann::json j = {{"file", path},
                              {"kind", "sweep_results"},
                              {"format", format},
                              {"rows", rows.size()},
                              {"records", records},
                              {"blocks", blocks.size()},
                              {"models", models},
                              {"overturned", overturned},
                              {"pga_g_min", any ? nlohmann::json(pga_min) : nlohmann::json(nullptr)},
                              {"pga_g_max", any ? nlohmann::json(pga_max) : nlohmann::json(nullptr)},
                              {"units", {{"pga_g_min", "g"}, {"pga_g_max", "g"}}}};
    return exporter::JsonText(j, 2) + "\n";
  }
  std::string model_list;
  for (const std::string& m : models) model_list += (model_list.empty() ? "" : ", ") + m;
  return path + ": rocklab sweep results (" + format + ")\n  " + std::to_string(rows.size()) + " rows: " +
         std::to_string(records.size()) + " records x " + std::to_string(blocks.size()) + " blocks (" + model_list +
         "), PGA " + (any ? Fixed("%.4g", pga_min) + " to " + Fixed("%.4g", pga_max) + " g" : "-") + "\n  " +
         std::to_string(overturned) + " overturned\n  (rocklab sweep-plot draws them)\n";
}

}  // namespace

/// When `path` is a ground-motion record or a sweep's results, its summary
/// (text, or JSON with `json`) into `text` and true; false for anything
/// else (LCM logs and raw files are cmd_info.cpp's).
/// @throws std::runtime_error naming FILE:LINE for a bad file of those kinds.
bool InfoOfOtherFormats(const std::string& path, bool json, std::string& text) {
  if (sweep::IsHdf5File(path)) {
    text = SweepResults(path, "HDF5", json);
    return true;
  }
  const std::string first = FirstLine(path);
  if (EndsWithNoCase(path, ".at2")) {
    text = GroundMotion(path, "PEER NGA .AT2", json);
    return true;
  }
  std::string header;
  for (char c : first) {
    if (c != ' ' && c != '\t' && c != '\r') header += c;
  }
  if (header == "time,accel") {
    text = GroundMotion(path, "time,accel CSV", json);
    return true;
  }
  if (IsSweepHeader(header)) {
    text = SweepResults(path, "CSV", json);
    return true;
  }
  return false;
}

}  // namespace rocklab::tools
