#pragma once
/// @file
/// Every field of every rocklab LCM type as table columns, from the field
/// tables of common/field_tables.h (lcm-gen's C++ types have no
/// reflection); tests/export/roundtrip_test.cpp fails when an .lcm file has
/// a field its table does not name, or a type has no table.
///
/// Columns of a message: `time` (s, the sample clock: utime / 1e6) first,
/// then the fields in .lcm order; an array field `values[n]` becomes
/// values_0 .. values_{n-1} (n from the channel's first message); int8..int64
/// and boolean are integer columns, double a real column, string a text
/// column. An integer field with named values (FieldCodes: kind, flags,
/// regime, equations, accel_source) carries them in its Column::codes (an
/// integer array's columns, flags_0 .. of block_state2_t, the field's); an
/// event's `kind` also gets a text column kind_name after all the fields
/// (the code's name; a value without a name in decimal).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "export/table.h"

namespace rocklab::common {
struct WireLayout;
}

namespace rocklab::exporter {

/// Decodes one rocklab type and turns it into a row. Not thread-safe; holds
/// the last decoded message.
class MessageDecoder {
 public:
  virtual ~MessageDecoder() = default;
  /// nullptr when `size` bytes at `data` decoded (common::GuardedDecode),
  /// else the reason. Never throws.
  virtual const char* Decode(const void* data, int size) = 0;
  /// The columns of the last decoded message (arrays sized by it); also
  /// fixes the array lengths Fill pads or cuts to.
  virtual void Columns(std::vector<Column>& columns) = 0;
  /// The last decoded message as a row of Columns()' layout. An array
  /// longer than at Columns() is cut, a shorter one padded (NaN, 0, "");
  /// returns false when it had to (the caller counts it).
  virtual bool Fill(Row& row) = 0;
  /// The last decoded message's utime, us (every rocklab type has one).
  virtual std::int64_t utime() const = 0;
  /// Whether the type carries a sample sequence number, and the last one.
  virtual bool has_seq() const = 0;
  virtual std::int64_t seq() const = 0;
};

struct MessageType {
  const char* name{};          ///< lcm-gen's type name without the package ("block_state_t")
  std::int64_t fingerprint{};  ///< Msg::getHash(): the payload's first 8 bytes
  const common::WireLayout* layout{};  ///< for common::WireCheck without decoding
  std::unique_ptr<MessageDecoder> (*make)(){};
  /// The field names in .lcm order (arrays once, by their name), no `time`.
  std::vector<std::string> (*field_names)(){};
};

/// The named values of an integer field by its name (in whatever type it
/// is), nullptr when it has none; *bitmask (may be null) says whether they
/// are bits.
const std::vector<Code>* FieldCodes(const std::string& field, bool* bitmask = nullptr);

/// Every rocklab type, in lcm_types/ file-name order.
const std::vector<MessageType>& MessageTypes();
/// The type with this fingerprint, nullptr when it is not a rocklab type.
const MessageType* FindMessageType(std::int64_t fingerprint);

}  // namespace rocklab::exporter
