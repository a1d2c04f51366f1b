// Every rocklab LCM type as table columns (see fields.h), from
// common/field_tables.h's field tables: the visitors below turn one table
// into the field names, the columns and a row.
#include "export/fields.h"

#include <cmath>
#include <limits>
#include <utility>
#include <type_traits>

#include "common/field_tables.h"
#include "common/wire.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/band_comparison_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison3_t.hpp"
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
#include "rocklab/model_state4_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::exporter {
namespace {

// ---- the field tables -------------------------------------------------------
// common/field_tables.h's, turned into the calls the visitors below take:
// one Visit per type, binding the message to the table's accessors.

// Calls the column visitor `v` for each field of `m` as `Table` lists it;
// a field whose accessor gives an array becomes an array call.
template <class M, class V>
struct Bound {
  const M& m;
  V& v;
  template <class G>
  void Int(const char* name, const char* unit, G get, unsigned = 0) {
    const auto& x = get(m);
    if constexpr (common::kIsArray<decltype(x)>) {
      v.IntArray(name, x, unit);
    } else {
      v.Int(name, static_cast<std::int64_t>(x), unit);
    }
  }
  template <class G>
  void Real(const char* name, const char* unit, G get, unsigned = 0) {
    const auto& x = get(m);
    if constexpr (common::kIsArray<decltype(x)>) {
      v.RealArray(name, x, unit);
    } else {
      v.Real(name, x, unit);
    }
  }
  template <class G>
  void Text(const char* name, G get) {
    const auto& x = get(m);
    if constexpr (common::kIsArray<decltype(x)>) {
      v.TextArray(name, x);
    } else {
      v.Text(name, x);
    }
  }
};

#define ROCKLAB_VISIT(type, table)                 \
  template <class V>                               \
  void Visit(const rocklab::type& m, V& v) {       \
    Bound<rocklab::type, V> b{m, v};               \
    common::table<rocklab::type>(b);               \
  }
ROCKLAB_VISIT(band_comparison_t, BandComparisonFields)
ROCKLAB_VISIT(block_state_t, BlockStateFields)
ROCKLAB_VISIT(block_state2_t, BlockStateFields)
ROCKLAB_VISIT(comparison_t, ComparisonFields)
ROCKLAB_VISIT(comparison2_t, ComparisonFields)
ROCKLAB_VISIT(comparison3_t, ComparisonFields)
ROCKLAB_VISIT(daq_config_t, DaqConfigFields)
ROCKLAB_VISIT(daq_config2_t, DaqConfigFields)
ROCKLAB_VISIT(event_t, EventFields)
ROCKLAB_VISIT(event2_t, EventFields)
ROCKLAB_VISIT(health_t, HealthFields)
ROCKLAB_VISIT(health2_t, HealthFields)
ROCKLAB_VISIT(model_band_t, ModelBandFields)
ROCKLAB_VISIT(model_state_t, ModelStateFields)
ROCKLAB_VISIT(model_state2_t, ModelStateFields)
ROCKLAB_VISIT(model_state3_t, ModelStateFields)
ROCKLAB_VISIT(model_state4_t, ModelStateFields)
ROCKLAB_VISIT(raw_frame_t, RawFrameFields)
ROCKLAB_VISIT(table_state_t, TableStateFields)
#undef ROCKLAB_VISIT

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
  template <class I>
  void IntArray(const char* n, const std::vector<I>&, const char*) { names.emplace_back(n); }
  void TextArray(const char* n, const std::vector<std::string>&) { names.emplace_back(n); }
};

// Columns of one message; records each array's length, and the field each
// integer array's columns come from (its legend is the field's).
struct ColumnVisitor {
  std::vector<Column>* columns;
  std::vector<std::size_t>* array_sizes;
  std::vector<std::pair<std::size_t, const char*>>* int_array_columns;
  void Int(const char* n, std::int64_t, const char* unit) {
    columns->push_back({n, ColumnType::kInt, unit});
  }
  template <class I>
  void IntArray(const char* n, const std::vector<I>& a, const char* unit) {
    array_sizes->push_back(a.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      int_array_columns->emplace_back(columns->size(), n);
      columns->push_back({std::string(n) + "_" + std::to_string(k), ColumnType::kInt, unit});
    }
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
  template <class I>
  void IntArray(const char*, const std::vector<I>& a, const char*) {
    const std::size_t n = (*array_sizes)[array++];
    reshaped = reshaped || a.size() != n;
    for (std::size_t k = 0; k < n; ++k) row->integer[i++] = k < a.size() ? static_cast<std::int64_t>(a[k]) : 0;
  }
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
    std::vector<std::pair<std::size_t, const char*>> int_array_columns;
    ColumnVisitor v{&columns, &array_sizes_, &int_array_columns};
    Visit(msg_, v);
    // Integer fields with named values: the legend on the column (an
    // array's columns: the field's legend), and for some
    // (Legend::name_column) a text column FIELD_name after the fields
    // (appended: the fields keep their positions).
    const std::size_t fields = columns.size();
    std::size_t next_array_column = 0;
    for (std::size_t i = 0; i < fields; ++i) {
      if (columns[i].type != ColumnType::kInt) continue;
      const char* field = columns[i].name.c_str();
      if (next_array_column < int_array_columns.size() && int_array_columns[next_array_column].first == i) {
        field = int_array_columns[next_array_column++].second;
      }
      const Legend* legend = FindLegend(field);
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
  bool has_seq() const override { return common::kHasSeq<Msg>; }
  std::int64_t seq() const override {
    if constexpr (common::kHasSeq<Msg>) {
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
      Entry<rocklab::block_state2_t>("block_state2_t"),
      Entry<rocklab::block_state_t>("block_state_t"),
      Entry<rocklab::comparison3_t>("comparison3_t"),
      Entry<rocklab::comparison2_t>("comparison2_t"),
      Entry<rocklab::comparison_t>("comparison_t"),
      Entry<rocklab::daq_config2_t>("daq_config2_t"),
      Entry<rocklab::daq_config_t>("daq_config_t"),
      Entry<rocklab::event2_t>("event2_t"),
      Entry<rocklab::event_t>("event_t"),
      Entry<rocklab::health2_t>("health2_t"),
      Entry<rocklab::health_t>("health_t"),
      Entry<rocklab::model_band_t>("model_band_t"),
      Entry<rocklab::model_state4_t>("model_state4_t"),
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
