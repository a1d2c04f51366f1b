// LiveState: the state as the page's JSON (a full snapshot or what changed
// since a cursor).
#include "monitor/live_state_impl.h"

namespace rocklab::monitor {

using namespace live_detail;  // NOLINT(google-build-using-namespace): the private helpers of live_state_impl.h

namespace {

json Number(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

}  // namespace

json LiveState::Impl::Update(std::uint64_t cursor) const {
  UpdateWindow w;
  w.cursor = cursor;
  w.full = cursor == 0 || cursor < record_start_seq;
  const bool windowed = std::isfinite(options.window_s) && has_clock;
  w.from_utime = windowed ? latest_utime - static_cast<std::int64_t>(std::llround(options.window_s * 1e6))
                          : std::numeric_limits<std::int64_t>::min();

  json doc;
  doc["schema"] = "rocklab.monitor.v1";
  doc["full"] = w.full;
  doc["cursor"] = seq;
  doc["record"] = record;
  doc["t0_utime"] = has_clock ? json(t0_utime) : json(nullptr);
  doc["t_latest"] = has_clock ? json(T(latest_utime)) : json(nullptr);
  doc["window_s"] = Number(options.window_s);
  doc["series_rate_hz"] = options.series_rate_hz;
  doc["max_points"] = options.max_points > 0 ? json(options.max_points) : json(nullptr);
  doc["from_s"] = options.from_s;
  doc["to_s"] = Number(options.to_s);
  doc["measured"] = SeriesJson(measured, "theta_deg", nullptr, w);
  json table_doc = SeriesJson(table, "accel_mps2", nullptr, w);
  table_doc["samples"] = table_samples;
  table_doc["peak_accel_mps2"] = table_peak_accel;
  table_doc["peak_disp_m"] = table_peak_disp;
  doc["table"] = std::move(table_doc);
  doc["variants"] = VariantsJson(w);
  // An assembly only (RL_BODIES, or a model of several bodies): a single
  // block's document keeps its keys.
  bool any_bodies = !measured_bodies.empty() || dropped_bodies > 0;
  for (const auto& v : variants) any_bodies = any_bodies || !v->bodies.empty();
  if (any_bodies) {
    json measured_list = json::array();
    for (const auto& s : measured_bodies) measured_list.push_back(SeriesJson(*s, "theta_deg", nullptr, w));
    doc["bodies"] = {{"measured", std::move(measured_list)}, {"dropped", dropped_bodies}};
  }
  doc["bands"] = BandsJson(w);
  doc["flags"] = FlagsJson(w);
  doc["events"] = EventsJson(w);
  doc["health"] = HealthJson();
  doc["config"] = has_config ? json{{"rig_name", rig_name},
                                    {"calibration_id", calibration_id},
                                    {"sample_rate_hz", Number(sample_rate_hz)},
                                    {"alpha", Number(alpha)},
                                    {"p", Number(p)},
                                    {"mu", Number(mu)}}
                             : json(nullptr);
  doc["counters"] = CountersJson();
  doc["units"] = UnitsJson();
  return doc;
}

// One series as {"t": [...], "<a_name>": [...] (, "<b_name>": [...])}: the
// points the update carries (in the window, or after the cursor).
json LiveState::Impl::SeriesJson(const Series& s, const char* a_name, const char* b_name,
                                 const UpdateWindow& w) const {
  json t = json::array(), a = json::array(), b = json::array();
  const std::size_t first = w.full ? s.FirstFrom(w.from_utime) : s.FirstAfter(w.cursor);
  for (std::size_t i = first; i < s.size(); ++i) {
    t.push_back(T(s[i].utime));
    a.push_back(Number(s[i].a));
    if (b_name) b.push_back(Number(s[i].b));
  }
  json out = {{"t", std::move(t)}, {a_name, std::move(a)}};
  if (b_name) out[b_name] = std::move(b);
  return out;
}

json LiveState::Impl::VariantsJson(const UpdateWindow& w) const {
  json variant_list = json::array();
  for (const auto& v : variants) {
    json j = {{"name", v->name}};
    if (v->has_params) {
      j["model"] = v->params.model;
      j["alpha"] = Number(v->params.alpha);
      j["p"] = Number(v->params.p);
      j["mu"] = Number(v->params.mu);
      j["l"] = Number(v->params.l);
      const char* equations = EquationsName(v->params.equations);
      j["equations"] = equations != nullptr ? json(equations) : json(nullptr);
    } else {
      for (const char* k : {"model", "alpha", "p", "mu", "l", "equations"}) j[k] = nullptr;
    }
    j["theta"] = SeriesJson(v->theta, "theta_deg", nullptr, w);
    j["comparison"] = SeriesJson(v->comparison, "error_deg", "rms_window_deg", w);
    if (v->has_latest) {
      const rocklab::comparison2_t& m = v->latest;
      j["latest"] = {{"utime", m.utime},
                     {"t", T(m.utime)},
                     {"error", Number(m.error)},
                     {"rms_window", Number(m.rms_window)},
                     {"window_s", Number(m.window_s)},
                     {"rms_total", Number(m.rms_total)},
                     {"nrms", Number(m.nrms)},
                     {"peak_error", Number(m.peak_error)},
                     {"impact_timing_error", Number(m.impact_timing_error)},
                     {"correlation", Number(m.correlation)},
                     {"valid", m.valid != 0},
                     {"samples", m.samples}};
    } else {
      j["latest"] = nullptr;
    }
    if (!v->bodies.empty() || v->has_bodies_latest) {
      json theta_list = json::array();
      for (const auto& s : v->bodies) theta_list.push_back(SeriesJson(*s, "theta_deg", nullptr, w));
      j["bodies"] = std::move(theta_list);
      if (v->has_bodies_latest) {
        const rocklab::comparison3_t& m = v->bodies_latest;
        auto numbers = [](const std::vector<double>& x) {
          json a = json::array();
          for (double d : x) a.push_back(Number(d));
          return a;
        };
        json valid = json::array();
        for (auto b : m.valid) valid.push_back(b != 0);
        j["bodies_latest"] = {{"utime", m.utime},
                              {"t", T(m.utime)},
                              {"nbodies", m.nbodies},
                              {"error", numbers(m.error)},
                              {"rms_window", numbers(m.rms_window)},
                              {"window_s", Number(m.window_s)},
                              {"rms_total", numbers(m.rms_total)},
                              {"nrms", numbers(m.nrms)},
                              {"peak_error", numbers(m.peak_error)},
                              {"impact_timing_error", numbers(m.impact_timing_error)},
                              {"correlation", numbers(m.correlation)},
                              {"valid", std::move(valid)},
                              {"samples", m.samples},
                              {"mode_model", m.mode_model},
                              {"mode_measured", m.mode_measured},
                              {"mode_rest_rad", Number(m.mode_rest_rad)},
                              {"mode_agreement", Number(m.mode_agreement)},
                              {"mode_samples", m.mode_samples}};
      } else {
        j["bodies_latest"] = nullptr;
      }
    }
    j["whole"] = {{"peak_theta", v->peak_abs_theta},
                  {"peak_theta_measured", measured_peak_abs_theta},
                  {"impact_timings", v->timing_count},
                  {"impact_timing_rms",
                   v->timing_count > 0 ? json(std::sqrt(v->timing_sum_sq / static_cast<double>(v->timing_count)))
                                       : json(nullptr)}};
    variant_list.push_back(std::move(j));
  }
  return variant_list;
}

// Each band as {name, model, draws, members, band: {t, median_deg, lo68_deg,
// hi68_deg, lo95_deg, hi95_deg}, latest: RL_COVERAGE's newest or null}.
json LiveState::Impl::BandsJson(const UpdateWindow& w) const {
  json band_list = json::array();
  for (const auto& b : bands) {
    json j = {{"name", b->name}};
    if (b->has_params) {
      j["model"] = b->model;
      j["draws"] = b->draws;
      j["members"] = b->members;
    } else {
      for (const char* k : {"model", "draws", "members"}) j[k] = nullptr;
    }
    json t = json::array(), median = json::array(), lo68 = json::array(), hi68 = json::array(),
         lo95 = json::array(), hi95 = json::array();
    const std::size_t n = std::min({b->median.size(), b->band68.size(), b->band95.size()});
    const std::size_t first = w.full ? b->median.FirstFrom(w.from_utime) : b->median.FirstAfter(w.cursor);
    for (std::size_t i = first; i < n; ++i) {
      t.push_back(T(b->median[i].utime));
      median.push_back(Number(b->median[i].a));
      lo68.push_back(Number(b->band68[i].a));
      hi68.push_back(Number(b->band68[i].b));
      lo95.push_back(Number(b->band95[i].a));
      hi95.push_back(Number(b->band95[i].b));
    }
    j["band"] = {{"t", std::move(t)},           {"median_deg", std::move(median)},
                 {"lo68_deg", std::move(lo68)}, {"hi68_deg", std::move(hi68)},
                 {"lo95_deg", std::move(lo95)}, {"hi95_deg", std::move(hi95)}};
    if (b->has_latest) {
      const rocklab::band_comparison_t& m = b->latest;
      j["latest"] = {{"utime", m.utime},
                     {"t", T(m.utime)},
                     {"window_s", Number(m.window_s)},
                     {"coverage95_window", Number(m.coverage95_window)},
                     {"coverage95_total", Number(m.coverage95_total)},
                     {"coverage68_window", Number(m.coverage68_window)},
                     {"coverage68_total", Number(m.coverage68_total)},
                     {"median_error", Number(m.median_error)},
                     {"width95", Number(m.width95)},
                     {"impact_timing_z", Number(m.impact_timing_z)},
                     {"impact_time_sd", Number(m.impact_time_sd)},
                     {"impact_timing_z_rms", Number(m.impact_timing_z_rms)},
                     {"matched_crossings", m.matched_crossings},
                     {"unmatched_crossings", m.unmatched_crossings},
                     {"valid", m.valid != 0},
                     {"samples", m.samples},
                     {"valid_samples", m.valid_samples}};
    } else {
      j["latest"] = nullptr;
    }
    band_list.push_back(std::move(j));
  }
  return band_list;
}

// The flag intervals, cut to the time window (from_s..to_s); an interval
// outside it is left out.
json LiveState::Impl::FlagsJson(const UpdateWindow& w) const {
  json flags = json::array();
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    const Interval& iv = intervals[i];
    const bool wanted = w.full ? (iv.open || iv.end >= w.from_utime) : iv.seq > w.cursor;
    if (!wanted) continue;
    const double start = std::max(T(iv.start), options.from_s);
    if ((!iv.open && T(iv.end) < options.from_s) || start > options.to_s) continue;
    const bool open_in_window = iv.open && !std::isfinite(options.to_s);
    const double end = iv.open ? options.to_s : std::min(T(iv.end), options.to_s);
    flags.push_back({{"id", iv.id},
                     {"flag", FlagName(iv.flag)},
                     {"source", iv.source},
                     {"start", start},
                     {"end", open_in_window ? json(nullptr) : json(end)}});
  }
  return flags;
}

json LiveState::Impl::EventsJson(const UpdateWindow& w) const {
  json event_list = json::array();
  for (std::size_t i = 0; i < events.size(); ++i) {
    const Event& e = events[i];
    if (w.full ? e.utime < w.from_utime : e.seq <= w.cursor) continue;
    event_list.push_back({{"t", T(e.utime)},
                          {"utime", e.utime},
                          {"source", e.source},
                          {"kind", EventKindName(e.kind)},
                          {"code", e.kind},
                          {"value", Number(e.value)},
                          {"detail", e.detail}});
  }
  return event_list;
}

json LiveState::Impl::HealthJson() const {
  json health_list = json::array();
  for (const auto& [node, h] : health) {
    health_list.push_back({{"node", node}, {"state", h.state}, {"utime", h.utime},
                           {"rate_in_hz", Number(h.rate_in_hz)}, {"rate_out_hz", Number(h.rate_out_hz)},
                           {"count_in", h.count_in}, {"count_out", h.count_out},
                           {"dropped", h.dropped}, {"gaps", h.gaps}, {"bad_samples", h.bad_samples},
                           {"lag_s", Number(h.lag_s)}});
  }
  return health_list;
}

json LiveState::Impl::CountersJson() const {
  json messages = json::object(), decode_errors = json::object(), seq_gaps = json::object(),
       seq_missing = json::object(), seq_disorder = json::object();
  for (const auto& [channel, c] : channels) {
    messages[channel] = c.messages;
    decode_errors[channel] = c.decode_errors;
    if (c.seq.any) {  // the channel's type carries a sequence number
      seq_gaps[channel] = c.seq.gaps;
      seq_missing[channel] = c.seq.missing;
      seq_disorder[channel] = {{"late", c.seq.late},
                               {"duplicates", c.seq.duplicates},
                               {"restarts", c.seq.restarts},
                               {"wild", c.seq.wild}};
    }
  }
  return json{{"messages", std::move(messages)},
              {"decode_errors", std::move(decode_errors)},
              {"seq_gaps", std::move(seq_gaps)},
              {"seq_missing", std::move(seq_missing)},
              {"seq_disorder", std::move(seq_disorder)},
              {"dropped",
               {{"out_of_order", dropped_out_of_order},
                {"events", dropped_events},
                {"intervals", dropped_intervals},
                {"variants", dropped_variants},
                {"nodes", dropped_nodes},
                {"channels", dropped_channels},
                {"far_from_clock", dropped_far_from_clock}}},
              {"outside_window", outside_window}};
}

json LiveState::Impl::UnitsJson() {
  return json{{"t", "s"}, {"t_latest", "s"}, {"t0_utime", "us"}, {"utime", "us"},
              {"window_s", "s"}, {"series_rate_hz", "Hz"}, {"theta_deg", "deg"},
              {"error_deg", "deg"}, {"rms_window_deg", "deg"}, {"error", "rad"},
              {"rms_window", "rad"}, {"rms_total", "rad"}, {"nrms", "1"},
              {"peak_error", "rad"}, {"impact_timing_error", "s"}, {"correlation", "1"},
              {"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"}, {"l", "1"},
              {"sample_rate_hz", "Hz"}, {"rate_in_hz", "Hz"}, {"rate_out_hz", "Hz"},
              {"lag_s", "s"}, {"start", "s"}, {"end", "s"}, {"accel_mps2", "m/s^2"},
              {"peak_accel_mps2", "m/s^2"}, {"peak_disp_m", "m"}, {"from_s", "s"}, {"to_s", "s"},
              {"median_deg", "deg"}, {"lo68_deg", "deg"}, {"hi68_deg", "deg"}, {"lo95_deg", "deg"},
              {"hi95_deg", "deg"}, {"coverage95_window", "1"}, {"coverage95_total", "1"},
              {"coverage68_window", "1"}, {"coverage68_total", "1"}, {"median_error", "rad"},
              {"width95", "rad"}, {"impact_timing_z", "1"}, {"impact_time_sd", "s"},
              {"impact_timing_z_rms", "1"}, {"peak_theta", "rad"}, {"peak_theta_measured", "rad"},
              {"impact_timings", "1"}, {"impact_timing_rms", "s"},
              {"value", "per event kind, see lcm_types/event2_t.lcm"}};
}

}  // namespace rocklab::monitor
