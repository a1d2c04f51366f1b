#include "report/report.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include <memory>

#include "common/lcm_log.h"
#include "common/text.h"
#include "common/wire.h"

#include "monitor/live_state.h"
#include "rocklab/table_state_t.hpp"
#include "common/units.h"

namespace rocklab::report {
namespace {

using nlohmann::json;

using common::kNaN;
constexpr std::size_t kMaxEvents = 20000;  // events and flag intervals listed, each (newest kept)
constexpr double kReadMargin_s = 5.0;       // read past the window's end, s (see ReadRecordLog)

using common::Format;

// A number of the snapshot; NaN where it is null (the snapshot's NaN) or absent.
double Number(const json& object, const char* key) {
  if (!object.is_object()) return kNaN;
  const auto it = object.find(key);
  return it != object.end() && it->is_number() ? it->get<double>() : kNaN;
}

std::string Text(const json& object, const char* key) {
  if (!object.is_object()) return {};
  const auto it = object.find(key);
  return it != object.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// {"t": [..], "<values>": [..]} of the snapshot as a curve (null -> NaN).
ThetaCurve Curve(const json& series, const char* values, std::string title, bool reference) {
  ThetaCurve c;
  c.title = std::move(title);
  c.reference = reference;
  if (!series.is_object() || !series.contains("t") || !series.contains(values)) return c;
  const json& t = series.at("t");
  const json& v = series.at(values);
  const std::size_t n = std::min(t.size(), v.size());
  c.time_s.reserve(n);
  c.theta_deg.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.time_s.push_back(t[i].is_number() ? t[i].get<double>() : kNaN);
    c.theta_deg.push_back(v[i].is_number() ? v[i].get<double>() : kNaN);
  }
  return c;
}

std::string ModelName(const std::string& model) {
  if (model == "complex") return "complex formulation";
  if (model == "housner") return "Housner model";
  return model.empty() ? std::string("model unknown") : model;
}

}  // namespace

void TablePeaks::Add(const rocklab::table_state_t& m) {
  ++samples;
  if (std::isfinite(m.acceleration)) accel_mps2 = std::fmax(accel_mps2, std::fabs(m.acceleration));
  if (std::isfinite(m.displacement)) disp_m = std::fmax(disp_m, std::fabs(m.displacement));
}

RecordReport ReadRecordLog(const std::string& log_path, const ReportOptions& options) {
  RecordReport r;
  r.log_path = log_path;
  common::LogReaderOptions read;
  read.on_problem = [&r](const common::LogProblem& p) { r.problems.push_back(ToString(p)); };
  // The reader's window is on the log's stamps (s after the first event);
  // LiveState cuts on the sample clock. rocklab's logs stamp each event with
  // the newest sample clock, so the two agree; the margin covers lcm-logger's
  // host-time stamps and lets the read stop soon after the window.
  if (std::isfinite(options.end_s)) read.end_s = options.end_s + kReadMargin_s;
  std::unique_ptr<common::LogReader> log;
  try {
    log = std::make_unique<common::LogReader>(log_path, read);
  } catch (const std::runtime_error& e) {
    throw ReportInputError(e.what());
  }

  monitor::LiveOptions live_options;
  live_options.window_s = std::numeric_limits<double>::infinity();  // the whole record
  live_options.series_rate_hz = options.series_rate_hz;
  live_options.max_points = options.max_points;
  live_options.from_s = options.start_s;
  live_options.to_s = options.end_s;
  live_options.channel_prefix = options.channel_prefix;
  // Every event and flag interval of the window is listed; the rings grow to
  // this bound (about 100 bytes each), beyond it the oldest go (counted).
  live_options.max_events = kMaxEvents;
  live_options.max_intervals = kMaxEvents;
  std::unique_ptr<monitor::LiveState> live;
  try {
    live = std::make_unique<monitor::LiveState>(live_options);
  } catch (const std::invalid_argument& e) {
    throw ReportInputError(std::string("report options: ") + e.what());
  }

  common::LogEvent ev;
  while (log->Next(ev)) {
    ++r.events;
    live->Ingest(ev.channel, ev.data.data(), static_cast<int>(ev.data.size()));  // counts every channel
  }
  r.damaged_regions = log->counts().damaged_regions;
  r.damaged_bytes = log->counts().damaged_bytes;
  r.damaged_events = log->counts().damaged_events;
  if (r.events == 0) {
    throw ReportInputError("'" + log_path + "' is not an LCM log (no LCM event in it)");
  }
  r.snapshot = live->Snapshot();
  live.reset();
  const json& table = r.snapshot.at("table");
  r.table.samples = table.at("samples").get<std::int64_t>();
  r.table.accel_mps2 = table.at("peak_accel_mps2").get<double>();
  r.table.disp_m = table.at("peak_disp_m").get<double>();
  r.table.decode_errors = r.snapshot.at("counters").at("decode_errors").value(
      options.channel_prefix + "TABLE", std::int64_t{0});
  const json& counters = r.snapshot.at("counters");
  const std::string theta_channel = options.channel_prefix + "THETA";
  const std::int64_t theta_count = counters.at("messages").value(theta_channel, std::int64_t{0});
  if (theta_count == 0) {
    throw ReportInputError("'" + log_path + "' has no " + theta_channel + " message (" +
                           std::to_string(r.events) +
                           " events on other channels): no measured theta to report");
  }
  if (r.snapshot.at("measured").at("t").empty() && std::isinf(options.end_s) &&
      options.start_s == 0) {
    throw ReportInputError("'" + log_path + "': none of its " + std::to_string(theta_count) + " " +
                           theta_channel + " messages decodes as rocklab::block_state_t");
  }
  for (const auto& [channel, n] : counters.at("decode_errors").items()) {
    r.decode_errors += n.get<std::int64_t>();
  }
  for (const auto& [channel, n] : counters.at("seq_missing").items()) {
    r.seq_missing += n.get<std::int64_t>();
  }
  if (r.snapshot.at("measured").at("t").empty()) {
    throw ReportInputError("'" + log_path + "': no " + theta_channel + " sample between " +
                           Format("%g s and %g s", options.start_s, options.end_s) +
                           " after the record's first sample (t = " +
                           Format("%.3f s", Number(r.snapshot, "t_latest")) + " is the last read)");
  }
  return r;
}

std::vector<std::string> CaptionLines(const RecordReport& record) {
  const json& s = record.snapshot;
  std::vector<std::string> lines;
  for (const json& v : s.at("variants")) {
    const std::string model = Text(v, "model");
    std::string line = Text(v, "name") + ": " + ModelName(model);
    line += Format(", alpha %.6g rad, p %.6g rad/s, mu %.6g", Number(v, "alpha"), Number(v, "p"),
                   Number(v, "mu"));
    if (model == "complex") line += Format(", l %.6g", Number(v, "l"));
    const json latest = v.value("latest", json());
    const double nrms = Number(latest, "nrms");
    line += std::isfinite(nrms) ? Format("; nrms %.3g", nrms) : std::string("; not compared");
    // RL_COMPARE's timing error is NaN (null here) until a crossing is matched.
    if (std::isfinite(nrms) && !std::isfinite(Number(latest, "impact_timing_error"))) {
      line += "; no zero crossing matched (no timing or peak error)";
    }
    lines.push_back(line);
    // An assembly: a line per body (RL_COMPAREBODIES_<name>), then its modes.
    const json bodies = v.value("bodies_latest", json());
    if (bodies.is_object()) {
      const json nrms_list = bodies.value("nrms", json::array());
      const json rms_list = bodies.value("rms_total", json::array());
      for (std::size_t k = 0; k < nrms_list.size(); ++k) {
        const double body_nrms = nrms_list[k].is_number() ? nrms_list[k].get<double>() : kNaN;
        const double body_rms = k < rms_list.size() && rms_list[k].is_number() ? rms_list[k].get<double>() : kNaN;
        lines.push_back(Text(v, "name") + Format(" body %zu: rms %.3g rad, nrms %.3g", k, body_rms, body_nrms));
      }
      const double agreement = Number(bodies, "mode_agreement");
      lines.push_back(Text(v, "name") +
                      (std::isfinite(agreement)
                           ? Format(": modes agree %.1f %% of the time", 100 * agreement)
                           : std::string(": modes not compared")) +
                      Format(" (rest below %.3g rad)", Number(bodies, "mode_rest_rad")));
    }
  }

  for (const json& b : s.value("bands", json::array())) {
    std::string line = Text(b, "name") + ": posterior predictive band, " + ModelName(Text(b, "model"));
    const json draws = b.value("draws", json());
    if (draws.is_number()) line += Format(", %lld draws", static_cast<long long>(draws.get<std::int64_t>()));
    const json latest = b.value("latest", json());
    const double c95 = Number(latest, "coverage95_total");
    if (std::isfinite(c95)) {
      line += Format("; measurement inside 95 %%: %.1f %%, inside 68 %%: %.1f %%", 100 * c95,
                     100 * Number(latest, "coverage68_total"));
      const double z = Number(latest, "impact_timing_z_rms");
      line += std::isfinite(z) ? Format("; impact timing z rms %.2g", z) : std::string("; no impact timing z");
    } else {
      line += "; not compared";
    }
    lines.push_back(line);
  }
  const json config = s.value("config", json());
  const std::string rig = Text(config, "rig_name");
  std::string scenario = "rig " + (rig.empty() ? std::string("unknown (no RL_DAQ_CONFIG)") : rig);
  const std::string calibration = Text(config, "calibration_id");
  if (!calibration.empty()) scenario += ", calibration " + calibration;
  const json& measured_t = s.at("measured").at("t");
  const double t_first = !measured_t.empty() && measured_t[0].is_number() ? measured_t[0].get<double>() : 0.0;
  const double t_latest = Number(s, "t_latest");
  const double from_s = Number(s, "from_s");
  const double to_s = Number(s, "to_s");  // NaN (null): to the end
  if ((std::isfinite(from_s) && from_s > 0) || std::isfinite(to_s)) {
    const double last = !measured_t.empty() && measured_t.back().is_number() ? measured_t.back().get<double>() : t_first;
    scenario += Format("; window %.3f s to %.3f s", t_first, last);
  } else {
    scenario += Format("; record %.3f s", std::isfinite(t_latest) ? t_latest - t_first : 0.0);
  }
  if (record.table.samples > 0) {
    scenario += Format("; peak table acceleration %.4g m/s^2, peak table displacement %.4g mm",
                       record.table.accel_mps2, record.table.disp_m * 1e3);
  } else {
    scenario += "; no table record (RL_TABLE)";
  }
  lines.push_back(scenario);
  return lines;
}

// The snapshot's {"t", "median_deg", ...} of a band as a figure band (null -> NaN).
ThetaBand Band(const json& band, std::string title) {
  ThetaBand b;
  b.title = std::move(title);
  if (!band.is_object() || !band.contains("t")) return b;
  const json& t = band.at("t");
  const std::pair<const char*, std::vector<double>*> quantiles[] = {
      {"lo95_deg", &b.lo95_deg}, {"lo68_deg", &b.lo68_deg}, {"median_deg", &b.median_deg},
      {"hi68_deg", &b.hi68_deg}, {"hi95_deg", &b.hi95_deg}};
  std::size_t n = t.size();
  for (const auto& [key, out] : quantiles) n = std::min(n, band.contains(key) ? band.at(key).size() : 0);
  auto value = [](const json& x) { return x.is_number() ? x.get<double>() : kNaN; };
  for (std::size_t i = 0; i < n; ++i) {
    b.time_s.push_back(value(t[i]));
    for (const auto& [key, out] : quantiles) out->push_back(value(band.at(key)[i]));
  }
  return b;
}

ThetaFigure ReportFigure(const RecordReport& record) {
  const json& s = record.snapshot;
  ThetaFigure figure;
  figure.set_title("rocking angle theta: experiment and models (" +
                   std::filesystem::path(record.log_path).filename().string() + ")");
  for (const json& b : s.value("bands", json::array())) {
    figure.AddBand(Band(b.value("band", json()), Text(b, "name") + " (" + ModelName(Text(b, "model")) + ")"));
  }
  figure.AddCurve(Curve(s.at("measured"), "theta_deg", "experiment", true));
  for (const json& v : s.at("variants")) {
    figure.AddCurve(Curve(v.value("theta", json()), "theta_deg",
                          Text(v, "name") + " (" + ModelName(Text(v, "model")) + ")", false));
  }
  // An assembly: its upper bodies a panel each (the panel above is body 0's,
  // RL_THETA's), the experiment's (RL_BODIES) and each variant's curve.
  const json measured_bodies = s.value("bodies", json::object()).value("measured", json::array());
  std::size_t nbodies = measured_bodies.size();
  for (const json& v : s.at("variants")) nbodies = std::max(nbodies, v.value("bodies", json::array()).size());
  for (std::size_t k = 1; k < nbodies; ++k) {
    std::vector<ThetaCurve> curves;
    if (k < measured_bodies.size()) curves.push_back(Curve(measured_bodies[k], "theta_deg", Format("experiment, body %zu", k), true));
    for (const json& v : s.at("variants")) {
      const json list = v.value("bodies", json::array());
      if (k < list.size()) {
        curves.push_back(Curve(list[k], "theta_deg", Text(v, "name") + Format(", body %zu", k), false));
      }
    }
    figure.AddBodyPanel(Format("theta, body %zu (degrees)", k), std::move(curves));
  }
  const ThetaCurve table = Curve(s.value("table", json()), "accel_mps2", "", false);
  if (!table.time_s.empty()) figure.SetTableAcceleration(table.time_s, table.theta_deg);
  for (std::string& line : CaptionLines(record)) figure.AddCaptionLine(std::move(line));
  return figure;
}

}  // namespace rocklab::report
