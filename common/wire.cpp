#include "common/wire.h"

#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "rocklab/band_comparison_t.hpp"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/health_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::common {
namespace {

thread_local char reason[192];

const char* Fail(const WireLayout& layout, const char* field, const char* what, std::int64_t value,
                 std::int64_t remaining) {
  std::snprintf(reason, sizeof reason, "%s.%s: %s %" PRId64 " with %" PRId64 " bytes remaining",
                layout.type, field, what, value, remaining);
  return reason;
}

std::int32_t ReadInt32(const std::uint8_t* p) {
  const std::uint32_t u = (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
                          (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  return static_cast<std::int32_t>(u);
}

// Field tables: one row per field of the .lcm file, in its order.
constexpr WireKind F = WireKind::kFixed;
constexpr WireKind S = WireKind::kString;
constexpr WireKind N = WireKind::kCount;
constexpr WireKind A = WireKind::kArray;
constexpr WireKind SA = WireKind::kStringArray;

template <class Msg, std::size_t K>
WireLayout Make(const char* type, const WireField (&fields)[K]) {
  return WireLayout{type, static_cast<std::int64_t>(Msg::getHash()), fields, static_cast<int>(K)};
}

const WireField kBandComparison[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "name"}, {F, 8, 0, "window_s"},
    {F, 8, 0, "coverage95_window"}, {F, 8, 0, "coverage95_total"}, {F, 8, 0, "coverage68_window"},
    {F, 8, 0, "coverage68_total"}, {F, 8, 0, "median_error"}, {F, 8, 0, "width95"},
    {F, 8, 0, "impact_timing_z"}, {F, 8, 0, "impact_time_sd"}, {F, 8, 0, "impact_timing_z_rms"},
    {F, 8, 0, "matched_crossings"}, {F, 8, 0, "unmatched_crossings"}, {F, 1, 0, "valid"},
    {F, 8, 0, "samples"}, {F, 8, 0, "valid_samples"}};
const WireField kBlockState[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {F, 8, 0, "theta"}, {F, 8, 0, "theta_dot"},
    {F, 8, 0, "theta_mirror"}, {F, 8, 0, "theta_camera"}, {F, 8, 0, "sliding"}, {F, 8, 0, "jump"},
    {F, 8, 0, "twist"}, {F, 8, 0, "out_of_plane"}, {F, 4, 0, "leds_used"}, {F, 4, 0, "flags"}};
// Per body (nbodies, field 2).
const WireField kBlockState2[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {N, 4, 0, "nbodies"}, {A, 8, 2, "theta"}, {A, 8, 2, "theta_dot"},
    {A, 8, 2, "theta_mirror"}, {A, 8, 2, "theta_camera"}, {A, 8, 2, "sliding"}, {A, 8, 2, "jump"},
    {A, 8, 2, "twist"}, {A, 8, 2, "out_of_plane"}, {A, 4, 2, "leds_used"}, {A, 4, 2, "flags"}};
#define ROCKLAB_COMPARISON_FIELDS                                                             \
  {S, 0, 0, "name"}, {F, 8, 0, "error"}, {F, 8, 0, "rms_window"}, {F, 8, 0, "window_s"},      \
      {F, 8, 0, "rms_total"}, {F, 8, 0, "nrms"}, {F, 8, 0, "peak_error"},                     \
      {F, 8, 0, "impact_timing_error"}, {F, 8, 0, "correlation"}, {F, 1, 0, "valid"},          \
      {F, 8, 0, "samples"}
const WireField kComparison[] = {{F, 8, 0, "utime"}, ROCKLAB_COMPARISON_FIELDS};
const WireField kComparison2[] = {{F, 8, 0, "utime"}, {F, 8, 0, "seq"}, ROCKLAB_COMPARISON_FIELDS};
#undef ROCKLAB_COMPARISON_FIELDS
// Per body (nbodies, field 3).
const WireField kComparison3[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "name"}, {N, 4, 0, "nbodies"}, {A, 8, 3, "error"},
    {A, 8, 3, "rms_window"}, {F, 8, 0, "window_s"}, {A, 8, 3, "rms_total"}, {A, 8, 3, "nrms"},
    {A, 8, 3, "peak_error"}, {A, 8, 3, "impact_timing_error"}, {A, 8, 3, "correlation"},
    {A, 1, 3, "valid"}, {F, 8, 0, "samples"}, {S, 0, 0, "mode_model"}, {S, 0, 0, "mode_measured"},
    {F, 8, 0, "mode_rest_rad"}, {F, 8, 0, "mode_agreement"}, {F, 8, 0, "mode_samples"}};
const WireField kDaqConfig[] = {
    {F, 8, 0, "utime"}, {S, 0, 0, "rig_name"}, {S, 0, 0, "calibration_id"},
    {F, 8, 0, "sample_rate_hz"}, {N, 4, 0, "num_channels"}, {SA, 0, 4, "channel_names"},
    {SA, 0, 4, "channel_units"}, {SA, 0, 4, "channel_sensors"}, {A, 8, 4, "gain"},
    {A, 8, 4, "offset"}, {F, 8, 0, "alpha"}, {F, 8, 0, "p"}, {F, 8, 0, "mu"}};
// As daq_config_t with seq at index 1: the arrays' count is field 5.
const WireField kDaqConfig2[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "rig_name"}, {S, 0, 0, "calibration_id"},
    {F, 8, 0, "sample_rate_hz"}, {N, 4, 0, "num_channels"}, {SA, 0, 5, "channel_names"},
    {SA, 0, 5, "channel_units"}, {SA, 0, 5, "channel_sensors"}, {A, 8, 5, "gain"},
    {A, 8, 5, "offset"}, {F, 8, 0, "alpha"}, {F, 8, 0, "p"}, {F, 8, 0, "mu"}};
const WireField kEvent[] = {{F, 8, 0, "utime"}, {S, 0, 0, "source"}, {F, 1, 0, "kind"},
                            {F, 8, 0, "value"}, {S, 0, 0, "detail"}};
const WireField kEvent2[] = {{F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "sender"},
                             {S, 0, 0, "source"}, {F, 1, 0, "kind"}, {F, 8, 0, "value"},
                             {S, 0, 0, "detail"}};
#define ROCKLAB_HEALTH_FIELDS                                                                 \
  {S, 0, 0, "node"}, {S, 0, 0, "state"}, {F, 8, 0, "rate_in_hz"}, {F, 8, 0, "rate_out_hz"},   \
      {F, 8, 0, "count_in"}, {F, 8, 0, "count_out"}, {F, 8, 0, "dropped"}, {F, 8, 0, "gaps"},  \
      {F, 8, 0, "bad_samples"}, {F, 8, 0, "lag_s"}
const WireField kHealth[] = {{F, 8, 0, "utime"}, ROCKLAB_HEALTH_FIELDS};
const WireField kHealth2[] = {{F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "sender"},
                              ROCKLAB_HEALTH_FIELDS};
#undef ROCKLAB_HEALTH_FIELDS
#define ROCKLAB_MODEL_STATE_FIELDS                                                            \
  {S, 0, 0, "name"}, {S, 0, 0, "model"}, {F, 8, 0, "theta"}, {F, 8, 0, "theta_dot"},          \
      {F, 8, 0, "chi"}, {F, 8, 0, "psi"}, {F, 8, 0, "energy"}, {F, 4, 0, "impact_count"},      \
      {F, 1, 0, "regime"}, {F, 8, 0, "alpha"}, {F, 8, 0, "p"}, {F, 8, 0, "mu"}, {F, 8, 0, "l"}
const WireField kModelState[] = {{F, 8, 0, "utime"}, ROCKLAB_MODEL_STATE_FIELDS};
const WireField kModelState2[] = {{F, 8, 0, "utime"}, ROCKLAB_MODEL_STATE_FIELDS, {F, 1, 0, "equations"}};
const WireField kModelState3[] = {{F, 8, 0, "utime"}, {F, 8, 0, "seq"}, ROCKLAB_MODEL_STATE_FIELDS,
                                  {F, 1, 0, "equations"}};
#undef ROCKLAB_MODEL_STATE_FIELDS
// Per body (nbodies, field 4).
const WireField kModelState4[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "name"}, {S, 0, 0, "model"}, {N, 4, 0, "nbodies"},
    {A, 8, 4, "theta"}, {A, 8, 4, "theta_dot"}, {A, 8, 4, "chi"}, {A, 8, 4, "psi"}, {F, 8, 0, "energy"},
    {F, 4, 0, "impact_count"}, {A, 1, 4, "regime"}, {A, 8, 4, "alpha"}, {A, 8, 4, "p"}, {A, 8, 4, "mu"},
    {F, 8, 0, "l"}, {F, 1, 0, "equations"}, {S, 0, 0, "mode"}};
const WireField kModelBand[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {S, 0, 0, "name"}, {S, 0, 0, "model"},
    {F, 4, 0, "draws"}, {F, 4, 0, "members"}, {F, 8, 0, "noise_sigma"}, {F, 8, 0, "theta_median"}, {F, 8, 0, "theta_lo95"},
    {F, 8, 0, "theta_lo68"}, {F, 8, 0, "theta_hi68"}, {F, 8, 0, "theta_hi95"},
    {F, 4, 0, "impacts_up"}, {F, 8, 0, "impact_up_offset_sum"}, {F, 8, 0, "impact_up_offset_sq_sum"},
    {F, 4, 0, "impacts_down"}, {F, 8, 0, "impact_down_offset_sum"},
    {F, 8, 0, "impact_down_offset_sq_sum"}};
const WireField kRawFrame[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {N, 4, 0, "num_channels"}, {A, 8, 2, "values"}};
const WireField kTableState[] = {
    {F, 8, 0, "utime"}, {F, 8, 0, "seq"}, {F, 8, 0, "displacement"}, {F, 8, 0, "velocity"},
    {F, 8, 0, "acceleration"}, {F, 1, 0, "accel_source"}};

}  // namespace

std::int64_t WireFingerprint(const void* data, int size) {
  if (data == nullptr || size < 8) return 0;
  const auto* b = static_cast<const std::uint8_t*>(data);
  std::uint64_t u = 0;
  for (int i = 0; i < 8; ++i) u = (u << 8) | b[i];
  return static_cast<std::int64_t>(u);
}

namespace {

const char* Walk(const WireLayout& layout, const void* data, int size, int* consumed, int* offsets,
                 int max_offsets, int* found) {
  if (data == nullptr || size < 8) return Fail(layout, "fingerprint", "message of", size, size);
  if (WireFingerprint(data, size) != layout.fingerprint) {
    std::snprintf(reason, sizeof reason, "%s: wrong fingerprint (another type)", layout.type);
    return reason;
  }
  const auto* b = static_cast<const std::uint8_t*>(data);
  std::int64_t pos = 8;
  // Counts read so far, by field index (rocklab types have a handful of fields).
  constexpr int kMaxFields = 64;
  if (layout.field_count > kMaxFields) {
    return Fail(layout, "(layout)", "more fields than the walker holds:", layout.field_count, 0);
  }
  std::int32_t counts[kMaxFields] = {};
  for (int i = 0; i < layout.field_count; ++i) {
    const WireField& f = layout.fields[i];
    const std::int64_t remaining = size - pos;
    switch (f.kind) {
      case WireKind::kFixed:
        if (f.bytes > remaining) return Fail(layout, f.name, "field of bytes", f.bytes, remaining);
        pos += f.bytes;
        break;
      case WireKind::kCount: {
        if (remaining < 4) return Fail(layout, f.name, "count field of bytes", 4, remaining);
        if (offsets != nullptr && *found < max_offsets) offsets[(*found)++] = static_cast<int>(pos);
        const std::int32_t n = ReadInt32(b + pos);
        pos += 4;
        // Each element takes at least one byte (a string at least 5): a
        // count larger than what remains can never decode.
        if (n < 0 || n > size - pos) return Fail(layout, f.name, "count", n, size - pos);
        counts[i] = n;
        break;
      }
      case WireKind::kArray: {
        const std::int64_t bytes = std::int64_t{counts[f.count_field]} * f.bytes;
        if (bytes > remaining) return Fail(layout, f.name, "array bytes", bytes, remaining);
        pos += bytes;
        break;
      }
      case WireKind::kString:
      case WireKind::kStringArray: {
        const std::int32_t n = f.kind == WireKind::kString ? 1 : counts[f.count_field];
        if (std::int64_t{n} * 5 > remaining) {
          return Fail(layout, f.name, "strings", n, remaining);
        }
        for (std::int32_t k = 0; k < n; ++k) {
          if (size - pos < 4) return Fail(layout, f.name, "string length field, bytes", 4, size - pos);
          if (offsets != nullptr && *found < max_offsets) offsets[(*found)++] = static_cast<int>(pos);
          const std::int32_t len = ReadInt32(b + pos);  // including the NUL
          pos += 4;
          if (len < 1 || len > size - pos) return Fail(layout, f.name, "string length", len, size - pos);
          // An LCM string is its bytes and one NUL: a NUL inside would be
          // decoded into the std::string but cut by encode's strlen (a node
          // republishing it would send a message shorter than its size).
          if (b[pos + len - 1] != 0 || std::memchr(b + pos, 0, static_cast<std::size_t>(len - 1)) != nullptr) {
            return Fail(layout, f.name, "string not NUL-terminated or with a NUL inside, length", len,
                        size - pos);
          }
          pos += len;
        }
        break;
      }
    }
  }
  // Bytes after the last field are left alone, as decode() leaves them.
  if (consumed != nullptr) *consumed = static_cast<int>(pos);
  return nullptr;
}

}  // namespace

const char* WireCheck(const WireLayout& layout, const void* data, int size, int* consumed) {
  return Walk(layout, data, size, consumed, nullptr, 0, nullptr);
}

int WireLengthOffsets(const WireLayout& layout, const void* data, int size, int* offsets, int max) {
  int found = 0;
  if (Walk(layout, data, size, nullptr, offsets, max, &found) != nullptr) return -1;
  return found;
}

#define ROCKLAB_WIRE_LAYOUT(T, table)                         \
  template <>                                                 \
  const WireLayout& WireLayoutOf<rocklab::T>() {              \
    static const WireLayout layout = Make<rocklab::T>(#T, table); \
    return layout;                                            \
  }
ROCKLAB_WIRE_LAYOUT(band_comparison_t, kBandComparison)
ROCKLAB_WIRE_LAYOUT(block_state_t, kBlockState)
ROCKLAB_WIRE_LAYOUT(block_state2_t, kBlockState2)
ROCKLAB_WIRE_LAYOUT(comparison_t, kComparison)
ROCKLAB_WIRE_LAYOUT(comparison2_t, kComparison2)
ROCKLAB_WIRE_LAYOUT(comparison3_t, kComparison3)
ROCKLAB_WIRE_LAYOUT(daq_config_t, kDaqConfig)
ROCKLAB_WIRE_LAYOUT(daq_config2_t, kDaqConfig2)
ROCKLAB_WIRE_LAYOUT(event_t, kEvent)
ROCKLAB_WIRE_LAYOUT(event2_t, kEvent2)
ROCKLAB_WIRE_LAYOUT(health_t, kHealth)
ROCKLAB_WIRE_LAYOUT(health2_t, kHealth2)
ROCKLAB_WIRE_LAYOUT(model_band_t, kModelBand)
ROCKLAB_WIRE_LAYOUT(model_state_t, kModelState)
ROCKLAB_WIRE_LAYOUT(model_state2_t, kModelState2)
ROCKLAB_WIRE_LAYOUT(model_state3_t, kModelState3)
ROCKLAB_WIRE_LAYOUT(model_state4_t, kModelState4)
ROCKLAB_WIRE_LAYOUT(raw_frame_t, kRawFrame)
ROCKLAB_WIRE_LAYOUT(table_state_t, kTableState)
#undef ROCKLAB_WIRE_LAYOUT

}  // namespace rocklab::common
