// One field table per rocklab LCM type (see fields.h). Each Visit lists the
// fields in .lcm order with their units (from the .lcm comments); the two
// visitors below turn one list into the columns and into a row.
#include "export/fields.h"

#include <cmath>
#include <limits>
#include <type_traits>

#include "common/wire.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/band_comparison_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/health_t.hpp"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::exporter {
namespace {

// ---- the field tables -------------------------------------------------------

template <class V>
void Visit(const rocklab::block_state_t& m, V& v) {
  v.Int("utime", m.utime, "us");
  v.Int("seq", m.seq, "");
  v.Real("theta", m.theta, "rad");
  v.Real("theta_dot", m.theta_dot, "rad/s");
  v.Real("theta_mirror", m.theta_mirror, "rad");
  v.Real("theta_camera", m.theta_camera, "rad");
  v.Real("sliding", m.sliding, "m");
  v.Real("jump", m.jump, "m");
  v.Real("twist", m.twist, "rad");
  v.Real("out_of_plane", m.out_of_plane, "m");
  v.Int("leds_used", m.leds_used, "");
  v.Int("flags", m.flags, "");
}

// The successors (comparison2_t, ...) list the older type's fields with
// `seq` after utime: one body for both.
template <class M, class V>
void VisitComparison(const M& m, V& v) {
  v.Int("utime", m.utime, "us");
  if constexpr (std::is_same_v<M, rocklab::comparison2_t>) v.Int("seq", m.seq, "");
  v.Text("name", m.name);
  v.Real("error", m.error, "rad");
  v.Real("rms_window", m.rms_window, "rad");
  v.Real("window_s", m.window_s, "s");
  v.Real("rms_total", m.rms_total, "rad");
  v.Real("nrms", m.nrms, "1");
  v.Real("peak_error", m.peak_error, "rad");
  v.Real("impact_timing_error", m.impact_timing_error, "s");
  v.Real("correlation", m.correlation, "1");
  v.Int("valid", m.valid, "");
  v.Int("samples", m.samples, "");
}

template <class V>
void Visit(const rocklab::comparison_t& m, V& v) {
  VisitComparison(m, v);
}

template <class V>
void Visit(const rocklab::comparison2_t& m, V& v) {
  VisitComparison(m, v);
}

template <class M, class V>
void VisitDaqConfig(const M& m, V& v) {
  v.Int("utime", m.utime, "us");
  if constexpr (std::is_same_v<M, rocklab::daq_config2_t>) v.Int("seq", m.seq, "");
  v.Text("rig_name", m.rig_name);
  v.Text("calibration_id", m.calibration_id);
  v.Real("sample_rate_hz", m.sample_rate_hz, "Hz");
  v.Int("num_channels", m.num_channels, "");
  v.TextArray("channel_names", m.channel_names);
  v.TextArray("channel_units", m.channel_units);
  v.TextArray("channel_sensors", m.channel_sensors);
  v.RealArray("gain", m.gain, "");
  v.RealArray("offset", m.offset, "");
  v.Real("alpha", m.alpha, "rad");
  v.Real("p", m.p, "rad/s");
  v.Real("mu", m.mu, "1");
}

template <class V>
void Visit(const rocklab::daq_config_t& m, V& v) {
  VisitDaqConfig(m, v);
}

template <class V>
void Visit(const rocklab::daq_config2_t& m, V& v) {
  VisitDaqConfig(m, v);
}

template <class M, class V>
void VisitEvent(const M& m, V& v) {
  v.Int("utime", m.utime, "us");
  if constexpr (std::is_same_v<M, rocklab::event2_t>) {
    v.Int("seq", m.seq, "");
    v.Text("sender", m.sender);
  }
  v.Text("source", m.source);
  v.Int("kind", m.kind, "");
  v.Real("value", m.value, "");  // the unit depends on kind (event_t.lcm)
  v.Text("detail", m.detail);
}

template <class V>
void Visit(const rocklab::event_t& m, V& v) {
  VisitEvent(m, v);
}

template <class V>
void Visit(const rocklab::event2_t& m, V& v) {
  VisitEvent(m, v);
}

template <class M, class V>
void VisitHealth(const M& m, V& v) {
  v.Int("utime", m.utime, "us");
  if constexpr (std::is_same_v<M, rocklab::health2_t>) {
    v.Int("seq", m.seq, "");
    v.Text("sender", m.sender);
  }
  v.Text("node", m.node);
  v.Text("state", m.state);
  v.Real("rate_in_hz", m.rate_in_hz, "Hz");
  v.Real("rate_out_hz", m.rate_out_hz, "Hz");
  v.Int("count_in", m.count_in, "");
  v.Int("count_out", m.count_out, "");
  v.Int("dropped", m.dropped, "");
  v.Int("gaps", m.gaps, "");
  v.Int("bad_samples", m.bad_samples, "");
  v.Real("lag_s", m.lag_s, "s");
}

template <class V>
void Visit(const rocklab::health_t& m, V& v) {
  VisitHealth(m, v);
}

template <class V>
void Visit(const rocklab::health2_t& m, V& v) {
  VisitHealth(m, v);
}

// model_state_t, model_state2_t and model_state3_t share their fields (3: seq after utime).
template <class M, class V>
void VisitModelState(const M& m, V& v) {
  v.Int("utime", m.utime, "us");
  if constexpr (std::is_same_v<M, rocklab::model_state3_t>) v.Int("seq", m.seq, "");
  v.Text("name", m.name);
  v.Text("model", m.model);
  v.Real("theta", m.theta, "rad");
  v.Real("theta_dot", m.theta_dot, "rad/s");
  v.Real("chi", m.chi, "1");
  v.Real("psi", m.psi, "rad");
  v.Real("energy", m.energy, "1");
  v.Int("impact_count", m.impact_count, "");
  v.Int("regime", m.regime, "");
  v.Real("alpha", m.alpha, "rad");
  v.Real("p", m.p, "rad/s");
  v.Real("mu", m.mu, "1");
  v.Real("l", m.l, "1");
}

template <class V>
void Visit(const rocklab::model_state_t& m, V& v) {
  VisitModelState(m, v);
}

template <class V>
void Visit(const rocklab::model_state2_t& m, V& v) {
  VisitModelState(m, v);
  v.Int("equations", m.equations, "");
}

template <class V>
void Visit(const rocklab::model_state3_t& m, V& v) {
  VisitModelState(m, v);
  v.Int("equations", m.equations, "");
}

template <class V>
void Visit(const rocklab::model_band_t& m, V& v) {
  v.Int("utime", m.utime, "us");
  v.Int("seq", m.seq, "");
  v.Text("name", m.name);
  v.Text("model", m.model);
  v.Int("draws", m.draws, "");
  v.Int("members", m.members, "");
  v.Real("noise_sigma", m.noise_sigma, "rad");
  v.Real("theta_median", m.theta_median, "rad");
  v.Real("theta_lo95", m.theta_lo95, "rad");
  v.Real("theta_lo68", m.theta_lo68, "rad");
  v.Real("theta_hi68", m.theta_hi68, "rad");
  v.Real("theta_hi95", m.theta_hi95, "rad");
  v.Int("impacts_up", m.impacts_up, "");
  v.Real("impact_up_offset_sum", m.impact_up_offset_sum, "s");
  v.Real("impact_up_offset_sq_sum", m.impact_up_offset_sq_sum, "s^2");
  v.Int("impacts_down", m.impacts_down, "");
  v.Real("impact_down_offset_sum", m.impact_down_offset_sum, "s");
  v.Real("impact_down_offset_sq_sum", m.impact_down_offset_sq_sum, "s^2");
}

template <class V>
void Visit(const rocklab::band_comparison_t& m, V& v) {
  v.Int("utime", m.utime, "us");
  v.Int("seq", m.seq, "");
  v.Text("name", m.name);
  v.Real("window_s", m.window_s, "s");
  v.Real("coverage95_window", m.coverage95_window, "1");
  v.Real("coverage95_total", m.coverage95_total, "1");
  v.Real("coverage68_window", m.coverage68_window, "1");
  v.Real("coverage68_total", m.coverage68_total, "1");
  v.Real("median_error", m.median_error, "rad");
  v.Real("width95", m.width95, "rad");
  v.Real("impact_timing_z", m.impact_timing_z, "1");
  v.Real("impact_time_sd", m.impact_time_sd, "s");
  v.Real("impact_timing_z_rms", m.impact_timing_z_rms, "1");
  v.Int("matched_crossings", m.matched_crossings, "");
  v.Int("unmatched_crossings", m.unmatched_crossings, "");
  v.Int("valid", m.valid, "");
  v.Int("samples", m.samples, "");
  v.Int("valid_samples", m.valid_samples, "");
}

template <class V>
void Visit(const rocklab::raw_frame_t& m, V& v) {
  v.Int("utime", m.utime, "us");
  v.Int("seq", m.seq, "");
  v.Int("num_channels", m.num_channels, "");
  v.RealArray("values", m.values, "");  // raw units: RL_DAQ_CONFIG's gain and offset calibrate them
}

template <class V>
void Visit(const rocklab::table_state_t& m, V& v) {
  v.Int("utime", m.utime, "us");
  v.Int("seq", m.seq, "");
  v.Real("displacement", m.displacement, "m");
  v.Real("velocity", m.velocity, "m/s");
  v.Real("acceleration", m.acceleration, "m/s^2");
  v.Int("accel_source", m.accel_source, "");
}

// ---- the named values -------------------------------------------------------
// By field name, not by type: a later type (model_state3_t, ...) with a
// field of the same name and meaning gets its legend without an entry here.
// The values are the generated constants, so they cannot drift from the
// .lcm files; tests/export/metadata_test.cpp (LogMetadata.EveryLcmConstantIsNamedInALegend) fails when an .lcm file has a
// constant group no legend names.

// name_column: the field also gets a text column FIELD_name. Only event
// kinds: events are a few a second, so their names cost nothing, and they
// are what a reader filters on; a text column beside a 1 kHz field (flags,
// regime, equations) would take more room than the data (HDF5 keeps a
// variable-length string per row: +71 % on those tables of a 7 s test's
// .h5, docs/export.md), so those carry the legend only.
struct Legend {
  const char* field;
  bool bitmask;
  bool name_column;
  std::vector<Code> codes;
};

const std::vector<Legend>& Legends() {
  using B = rocklab::block_state_t;
  using E = rocklab::event_t;
  using M = rocklab::model_state2_t;
  using T = rocklab::table_state_t;
  static const std::vector<Legend> legends = {
      {"kind", false, true,
       {{E::UPLIFT, "UPLIFT"}, {E::IMPACT, "IMPACT"}, {E::REST, "REST"}, {E::OVERTURN, "OVERTURN"},
        {E::SLIDING, "SLIDING"}, {E::TWIST, "TWIST"}, {E::GAP, "GAP"}, {E::STALE, "STALE"}, {E::JUMP, "JUMP"},
        {E::OUT_OF_PLANE, "OUT_OF_PLANE"}, {E::DISAGREE, "DISAGREE"}, {E::RECOVERED, "RECOVERED"},
        {E::BAD_SAMPLE, "BAD_SAMPLE"}, {E::COMMENT, "COMMENT"}}},
      {"flags", true, false,
       {{B::FLAG_SLIDING, "SLIDING"}, {B::FLAG_JUMP, "JUMP"}, {B::FLAG_TWIST, "TWIST"},
        {B::FLAG_OUT_OF_PLANE, "OUT_OF_PLANE"}, {B::FLAG_DISAGREE, "DISAGREE"}, {B::FLAG_NO_MIRROR, "NO_MIRROR"},
        {B::FLAG_NO_CAMERA, "NO_CAMERA"}}},
      {"regime", false, false,
       {{M::REGIME_REST, "REST"}, {M::REGIME_ROCKING, "ROCKING"}, {M::REGIME_OVERTURNED, "OVERTURNED"}}},
      {"equations", false, false,
       {{M::EQUATIONS_UNKNOWN, "UNKNOWN"}, {M::EQUATIONS_HOUSNER, "HOUSNER"}, {M::EQUATIONS_EQ10, "EQ10"},
        {M::EQUATIONS_LIMIT, "LIMIT"}}},
      {"accel_source", false, false,
       {{T::ACCEL_ACCELEROMETER, "ACCELEROMETER"}, {T::ACCEL_DIFFERENTIATED, "DIFFERENTIATED"},
        {T::ACCEL_EXACT, "EXACT"}}},
  };
  return legends;
}

const Legend* FindLegend(const std::string& field) {
  for (const Legend& l : Legends()) {
    if (field == l.field) return &l;
  }
  return nullptr;
}

// The name of `value` under `column`'s codes into `out` (reusing its
// storage): an enumeration's constant, or a bitmask's set bits joined by
// '|' ("" for 0). A value or bits without a name are written in decimal.
void CodeName(const Column& column, std::int64_t value, std::string& out) {
  out.clear();
  if (!column.bitmask) {
    for (const Code& c : column.codes) {
      if (c.value == value) {
        out += c.name;
        return;
      }
    }
    out += std::to_string(value);
    return;
  }
  std::int64_t rest = value;
  for (const Code& c : column.codes) {
    if ((value & c.value) == c.value && c.value != 0) {
      if (!out.empty()) out += '|';
      out += c.name;
      rest &= ~c.value;
    }
  }
  if (rest != 0) {
    if (!out.empty()) out += '|';
    out += std::to_string(rest);
  }
}

// ---- the visitors -------------------------------------------------------------

// Field names in order, arrays once.
struct NameVisitor {
  std::vector<std::string> names;
  void Int(const char* n, std::int64_t, const char*) { names.emplace_back(n); }
  void Real(const char* n, double, const char*) { names.emplace_back(n); }
  void Text(const char* n, const std::string&) { names.emplace_back(n); }
  void RealArray(const char* n, const std::vector<double>&, const char*) { names.emplace_back(n); }
  void TextArray(const char* n, const std::vector<std::string>&) { names.emplace_back(n); }
};

// Columns of one message; records each array's length.
struct ColumnVisitor {
  std::vector<Column>* columns;
  std::vector<std::size_t>* array_sizes;
  void Int(const char* n, std::int64_t, const char* unit) {
    columns->push_back({n, ColumnType::kInt, unit});
  }
  void Real(const char* n, double, const char* unit) {
    columns->push_back({n, ColumnType::kDouble, unit});
  }
  void Text(const char* n, const std::string&) { columns->push_back({n, ColumnType::kString, ""}); }
  void RealArray(const char* n, const std::vector<double>& a, const char* unit) {
    array_sizes->push_back(a.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      columns->push_back({std::string(n) + "_" + std::to_string(k), ColumnType::kDouble, unit});
    }
  }
  void TextArray(const char* n, const std::vector<std::string>& a) {
    array_sizes->push_back(a.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      columns->push_back({std::string(n) + "_" + std::to_string(k), ColumnType::kString, ""});
    }
  }
};

// One message into a row laid out as ColumnVisitor said (index 0 is `time`).
struct RowVisitor {
  Row* row;
  const std::vector<std::size_t>* array_sizes;
  std::size_t i{1};
  std::size_t array{0};
  bool reshaped{false};
  void Int(const char*, std::int64_t x, const char*) { row->integer[i++] = x; }
  void Real(const char*, double x, const char*) { row->real[i++] = x; }
  void Text(const char*, const std::string& x) { row->text[i++] = x; }
  void RealArray(const char*, const std::vector<double>& a, const char*) {
    const std::size_t n = (*array_sizes)[array++];
    reshaped = reshaped || a.size() != n;
    for (std::size_t k = 0; k < n; ++k) {
      row->real[i++] = k < a.size() ? a[k] : std::numeric_limits<double>::quiet_NaN();
    }
  }
  void TextArray(const char*, const std::vector<std::string>& a) {
    const std::size_t n = (*array_sizes)[array++];
    reshaped = reshaped || a.size() != n;
    for (std::size_t k = 0; k < n; ++k) {
      if (k < a.size()) {
        row->text[i++] = a[k];
      } else {
        row->text[i++].clear();
      }
    }
  }
};

template <class M, class = void>
struct HasSeq : std::false_type {};
template <class M>
struct HasSeq<M, std::void_t<decltype(std::declval<M>().seq)>> : std::true_type {};

template <class Msg>
class TypedDecoder final : public MessageDecoder {
 public:
  const char* Decode(const void* data, int size) override {
    return common::GuardedDecode(data, size, msg_);
  }
  void Columns(std::vector<Column>& columns) override {
    columns.clear();
    array_sizes_.clear();
    named_.clear();
    columns.push_back({"time", ColumnType::kDouble, "s"});
    ColumnVisitor v{&columns, &array_sizes_};
    Visit(msg_, v);
    // Integer fields with named values: the legend on the column, and for
    // some (Legend::name_column) a text column FIELD_name after the fields
    // (appended: the fields keep their positions).
    const std::size_t fields = columns.size();
    for (std::size_t i = 0; i < fields; ++i) {
      if (columns[i].type != ColumnType::kInt) continue;
      const Legend* legend = FindLegend(columns[i].name);
      if (!legend) continue;
      columns[i].codes = legend->codes;
      columns[i].bitmask = legend->bitmask;
      if (!legend->name_column) continue;
      columns.push_back({columns[i].name + "_name", ColumnType::kString, ""});
      columns.back().description = legend->bitmask ? "the set bits of " + columns[i].name + " by name, '|' between"
                                                   : "the name of " + columns[i].name + "'s code";
      named_.push_back({i, columns.size() - 1, columns[i]});
    }
  }
  bool Fill(Row& row) override {
    row.real[0] = static_cast<double>(msg_.utime) / 1e6;  // correctly rounded (x * 1e-6 can be 1 ulp off)
    RowVisitor v{&row, &array_sizes_};
    Visit(msg_, v);
    for (const Named& n : named_) CodeName(n.column, row.integer[n.code], row.text[n.name]);
    return !v.reshaped;
  }
  std::int64_t utime() const override { return msg_.utime; }
  bool has_seq() const override { return HasSeq<Msg>::value; }
  std::int64_t seq() const override {
    if constexpr (HasSeq<Msg>::value) {
      return msg_.seq;
    } else {
      return 0;
    }
  }

 private:
  struct Named {
    std::size_t code;  // the integer column
    std::size_t name;  // its FIELD_name column
    Column column;     // with the codes
  };
  Msg msg_{};
  std::vector<std::size_t> array_sizes_;
  std::vector<Named> named_;
};

template <class Msg>
MessageType Entry(const char* name) {
  MessageType t;
  t.name = name;
  t.fingerprint = Msg::getHash();
  t.layout = &common::WireLayoutOf<Msg>();
  t.make = [] { return std::unique_ptr<MessageDecoder>(new TypedDecoder<Msg>()); };
  t.field_names = [] {
    NameVisitor v;
    Visit(Msg{}, v);
    return v.names;
  };
  return t;
}

}  // namespace

const std::vector<MessageType>& MessageTypes() {
  static const std::vector<MessageType> types = {
      Entry<rocklab::band_comparison_t>("band_comparison_t"),
      Entry<rocklab::block_state_t>("block_state_t"),
      Entry<rocklab::comparison2_t>("comparison2_t"),
      Entry<rocklab::comparison_t>("comparison_t"),
      Entry<rocklab::daq_config2_t>("daq_config2_t"),
      Entry<rocklab::daq_config_t>("daq_config_t"),
      Entry<rocklab::event2_t>("event2_t"),
      Entry<rocklab::event_t>("event_t"),
      Entry<rocklab::health2_t>("health2_t"),
      Entry<rocklab::health_t>("health_t"),
      Entry<rocklab::model_band_t>("model_band_t"),
      Entry<rocklab::model_state3_t>("model_state3_t"),
      Entry<rocklab::model_state2_t>("model_state2_t"),
      Entry<rocklab::model_state_t>("model_state_t"),
      Entry<rocklab::raw_frame_t>("raw_frame_t"),
      Entry<rocklab::table_state_t>("table_state_t"),
  };
  return types;
}

const std::vector<Code>* FieldCodes(const std::string& field, bool* bitmask) {
  const Legend* l = FindLegend(field);
  if (!l) return nullptr;
  if (bitmask) *bitmask = l->bitmask;
  return &l->codes;
}

const MessageType* FindMessageType(std::int64_t fingerprint) {
  for (const MessageType& t : MessageTypes()) {
    if (t.fingerprint == fingerprint) return &t;
  }
  return nullptr;
}

}  // namespace rocklab::exporter
