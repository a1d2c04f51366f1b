#pragma once
/// @file
/// The wire pre-check: before lcm-gen's decode() runs on bytes from the wire
/// or a file, walk the encoded layout of the rocklab type (fingerprint, fixed
/// fields, each length-prefixed string, each variable array's count) and
/// reject any length that exceeds the bytes that remain, or is negative, and
/// any string that is not its bytes plus one final NUL (lcm-gen decodes a NUL
/// inside into the std::string, then encodes with strlen: a node passing the
/// string on would publish a message shorter than its declared size).
///
/// Why: lcm-gen's decoders resize a vector (or a string array) from the
/// wire's count before they look at the buffer, so a count of 0x7f00000e
/// doubles allocates 17 GB before failing; a string length <= 0 makes
/// std::string::assign throw. After WireCheck accepts a message, decode()
/// allocates at most about the message's own size.
///
/// One layout per rocklab type (wire.cpp), written beside lcm_types/ and held
/// in step with it by tests/common/wire_test.cpp (every type round-trips
/// through encode, WireCheck and decode; every .lcm file has a layout; each
/// length field corrupted is rejected without allocation).
///
/// Cost: a walk over the fields (no allocation); on failure the reason is
/// written into a thread-local buffer.

#include <cstdint>
#include <exception>

namespace rocklab::common {

enum class WireKind : std::uint8_t {
  kFixed,        ///< `bytes` bytes (int8..int64, double, boolean)
  kString,       ///< int32 length including the NUL, then the bytes
  kCount,        ///< int32 array count (the dimension later arrays name)
  kArray,        ///< `count_field` elements of `bytes` bytes each
  kStringArray,  ///< `count_field` strings
};

struct WireField {
  WireKind kind{};
  int bytes{};        ///< kFixed: the field's size; kArray: one element's size
  int count_field{};  ///< kArray / kStringArray: index of the kCount field in the layout
  const char* name{};
};

struct WireLayout {
  const char* type{};
  std::int64_t fingerprint{};  ///< Msg::getHash(): the first 8 bytes, big-endian
  const WireField* fields{};
  int field_count{};
};

/// The layout of an lcm-gen rocklab type (specialised in wire.cpp for each
/// type in lcm_types/; a type without one does not link).
template <class Msg>
const WireLayout& WireLayoutOf();

/// nullptr when `size` bytes at `data` are a well-formed encoding of the
/// layout's type as far as lengths go (fingerprint, every length and count
/// within the bytes that remain; bytes after the last field are ignored, as
/// decode() ignores them); otherwise the reason, naming the type and field
/// (thread-local buffer, valid until the next call). `consumed`, when given
/// and the check passes: the bytes the fields take.
const char* WireCheck(const WireLayout& layout, const void* data, int size,
                      int* consumed = nullptr);

/// The byte offsets of every length field (string lengths, array counts) of
/// a message WireCheck accepts, in wire order, at most `max` of them; the
/// number found (-1 when WireCheck refuses the message). For tests that
/// corrupt each length in turn.
int WireLengthOffsets(const WireLayout& layout, const void* data, int size, int* offsets, int max);

/// The fingerprint in the first 8 bytes (big-endian); 0 when shorter.
std::int64_t WireFingerprint(const void* data, int size);

/// WireCheck, then lcm-gen's decode: nullptr when `msg` holds the message,
/// otherwise the reason (`msg` may then hold part of it). Never throws.
template <class Msg>
const char* GuardedDecode(const void* data, int size, Msg& msg) {
  if (const char* why = WireCheck(WireLayoutOf<Msg>(), data, size)) return why;
  try {
    if (msg.decode(data, 0, size) < 0) return "decode() failed after the pre-check";
  } catch (const std::exception&) {
    return "decode() threw after the pre-check";
  }
  return nullptr;
}

}  // namespace rocklab::common
