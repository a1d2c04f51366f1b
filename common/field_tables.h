#pragma once
/// @file
/// One field table per rocklab value: each field's name, unit and accessor,
/// written once and used by every copy and every output of the value (the
/// LCM copies and upgrades here and in daq/, export's CSV, MAT, HDF5 and
/// JSON tables, `rocklab reconstruct`'s CSV, Python's numpy columns).
/// lcm-gen's C++ types have no reflection; these tables are it.
///
/// A table is a function template `XFields<M>(v)` that calls, per field in
/// the .lcm order of M,
///   v.Int(name, unit, get)   int8..int64, boolean
///   v.Real(name, unit, get)  double
///   v.Text(name, get)        string
/// where `get(m)` returns a reference to that field of any struct with a
/// member of that name (the lcm-gen types, daq::BlockState). A field of a
/// per-body type (block_state2_t, model_state4_t) has the same name and
/// accessor as the single-body one; `get` then returns the array
/// (std::vector): visitors tell the two apart by the type (IsArray). Arrays
/// of a channel count (daq_config_t's, raw_frame_t's) come through the same
/// calls. Units: SI, "1" dimensionless, "" none (counts, codes, text).
///
/// The block state's fields take a fourth argument, the outputs beside the
/// LCM type that carry them (kInReconstructCsv): `rocklab reconstruct`'s
/// CSV header is a contract older than jump and leds_used.

#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace rocklab::common {

/// Whether a field's accessor returns an array (a std::vector).
template <class T>
struct IsArray : std::false_type {};
template <class T, class A>
struct IsArray<std::vector<T, A>> : std::true_type {};
template <class T>
inline constexpr bool kIsArray = IsArray<std::remove_cv_t<std::remove_reference_t<T>>>::value;

/// Outputs of a block-state field besides the LCM types (a bitmask).
enum BlockStateOutput : unsigned {
  kLcmOnly = 0,
  kInReconstructCsv = 1,  ///< a column of `rocklab reconstruct`'s CSV
};

namespace field_detail {
template <class M, class = void>
struct HasSeq : std::false_type {};
template <class M>
struct HasSeq<M, std::void_t<decltype(std::declval<M&>().seq)>> : std::true_type {};
template <class M, class = void>
struct HasSender : std::false_type {};
template <class M>
struct HasSender<M, std::void_t<decltype(std::declval<M&>().sender)>> : std::true_type {};
template <class M, class = void>
struct HasBodies : std::false_type {};
template <class M>
struct HasBodies<M, std::void_t<decltype(std::declval<M&>().nbodies)>> : std::true_type {};
template <class M, class = void>
struct HasEquations : std::false_type {};
template <class M>
struct HasEquations<M, std::void_t<decltype(std::declval<M&>().equations)>> : std::true_type {};
template <class M, class = void>
struct HasMode : std::false_type {};
template <class M>
struct HasMode<M, std::void_t<decltype(std::declval<M&>().mode)>> : std::true_type {};
}  // namespace field_detail

/// Whether a message type carries `seq` (the successors do, the first
/// versions of comparison, daq_config, event, health, model_state do not).
template <class M>
inline constexpr bool kHasSeq = field_detail::HasSeq<M>::value;

// The accessor of member `f` of whatever struct it is given.
#define ROCKLAB_FIELD(f) [](auto& m) -> auto& { return m.f; }

/// block_state_t and block_state2_t (nbodies after seq, then every field
/// below per body); daq::BlockState has them all.
template <class M, class V>
void BlockStateFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime), kLcmOnly);
  v.Int("seq", "", ROCKLAB_FIELD(seq), kLcmOnly);
  if constexpr (field_detail::HasBodies<M>::value) v.Int("nbodies", "", ROCKLAB_FIELD(nbodies), kLcmOnly);
  v.Real("theta", "rad", ROCKLAB_FIELD(theta), kInReconstructCsv);
  v.Real("theta_dot", "rad/s", ROCKLAB_FIELD(theta_dot), kInReconstructCsv);
  v.Real("theta_mirror", "rad", ROCKLAB_FIELD(theta_mirror), kInReconstructCsv);
  v.Real("theta_camera", "rad", ROCKLAB_FIELD(theta_camera), kInReconstructCsv);
  v.Real("sliding", "m", ROCKLAB_FIELD(sliding), kInReconstructCsv);
  v.Real("jump", "m", ROCKLAB_FIELD(jump), kLcmOnly);
  v.Real("twist", "rad", ROCKLAB_FIELD(twist), kInReconstructCsv);
  v.Real("out_of_plane", "m", ROCKLAB_FIELD(out_of_plane), kInReconstructCsv);
  v.Int("leds_used", "", ROCKLAB_FIELD(leds_used), kLcmOnly);
  v.Int("flags", "", ROCKLAB_FIELD(flags), kInReconstructCsv);
}

/// daq::BlockState's fields that no LCM type carries (Python's columns).
template <class V>
void BlockStateExtraFields(V& v) {
  v.Real("tilt", "rad", ROCKLAB_FIELD(tilt), kLcmOnly);
  v.Real("table_displacement", "m", ROCKLAB_FIELD(table_displacement), kLcmOnly);
  v.Real("table_acceleration", "m/s^2", ROCKLAB_FIELD(table_acceleration), kLcmOnly);
}

/// model_state_t, model_state2_t, model_state3_t (seq after utime) and
/// model_state4_t (also nbodies after model, mode last; per body: theta,
/// theta_dot, chi, psi, regime, alpha, p, mu).
template <class M, class V>
void ModelStateFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  if constexpr (field_detail::HasSeq<M>::value) v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Text("name", ROCKLAB_FIELD(name));
  v.Text("model", ROCKLAB_FIELD(model));
  if constexpr (field_detail::HasBodies<M>::value) v.Int("nbodies", "", ROCKLAB_FIELD(nbodies));
  v.Real("theta", "rad", ROCKLAB_FIELD(theta));
  v.Real("theta_dot", "rad/s", ROCKLAB_FIELD(theta_dot));
  v.Real("chi", "1", ROCKLAB_FIELD(chi));
  v.Real("psi", "rad", ROCKLAB_FIELD(psi));
  v.Real("energy", "1", ROCKLAB_FIELD(energy));
  v.Int("impact_count", "", ROCKLAB_FIELD(impact_count));
  v.Int("regime", "", ROCKLAB_FIELD(regime));
  v.Real("alpha", "rad", ROCKLAB_FIELD(alpha));
  v.Real("p", "rad/s", ROCKLAB_FIELD(p));
  v.Real("mu", "1", ROCKLAB_FIELD(mu));
  v.Real("l", "1", ROCKLAB_FIELD(l));
  if constexpr (field_detail::HasEquations<M>::value) v.Int("equations", "", ROCKLAB_FIELD(equations));
  if constexpr (field_detail::HasMode<M>::value) v.Text("mode", ROCKLAB_FIELD(mode));
}

/// comparison_t, comparison2_t (seq after utime) and comparison3_t (also
/// nbodies after name, the figures per body, the mode fields last).
template <class M, class V>
void ComparisonFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  if constexpr (field_detail::HasSeq<M>::value) v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Text("name", ROCKLAB_FIELD(name));
  if constexpr (field_detail::HasBodies<M>::value) v.Int("nbodies", "", ROCKLAB_FIELD(nbodies));
  v.Real("error", "rad", ROCKLAB_FIELD(error));
  v.Real("rms_window", "rad", ROCKLAB_FIELD(rms_window));
  v.Real("window_s", "s", ROCKLAB_FIELD(window_s));
  v.Real("rms_total", "rad", ROCKLAB_FIELD(rms_total));
  v.Real("nrms", "1", ROCKLAB_FIELD(nrms));
  v.Real("peak_error", "rad", ROCKLAB_FIELD(peak_error));
  v.Real("impact_timing_error", "s", ROCKLAB_FIELD(impact_timing_error));
  v.Real("correlation", "1", ROCKLAB_FIELD(correlation));
  v.Int("valid", "", ROCKLAB_FIELD(valid));
  v.Int("samples", "", ROCKLAB_FIELD(samples));
  if constexpr (field_detail::HasBodies<M>::value) {
    v.Text("mode_model", ROCKLAB_FIELD(mode_model));
    v.Text("mode_measured", ROCKLAB_FIELD(mode_measured));
    v.Real("mode_rest_rad", "rad", ROCKLAB_FIELD(mode_rest_rad));
    v.Real("mode_agreement", "1", ROCKLAB_FIELD(mode_agreement));
    v.Int("mode_samples", "", ROCKLAB_FIELD(mode_samples));
  }
}

/// daq_config_t and daq_config2_t (seq after utime).
template <class M, class V>
void DaqConfigFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  if constexpr (field_detail::HasSeq<M>::value) v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Text("rig_name", ROCKLAB_FIELD(rig_name));
  v.Text("calibration_id", ROCKLAB_FIELD(calibration_id));
  v.Real("sample_rate_hz", "Hz", ROCKLAB_FIELD(sample_rate_hz));
  v.Int("num_channels", "", ROCKLAB_FIELD(num_channels));
  v.Text("channel_names", ROCKLAB_FIELD(channel_names));
  v.Text("channel_units", ROCKLAB_FIELD(channel_units));
  v.Text("channel_sensors", ROCKLAB_FIELD(channel_sensors));
  v.Real("gain", "", ROCKLAB_FIELD(gain));
  v.Real("offset", "", ROCKLAB_FIELD(offset));
  v.Real("alpha", "rad", ROCKLAB_FIELD(alpha));
  v.Real("p", "rad/s", ROCKLAB_FIELD(p));
  v.Real("mu", "1", ROCKLAB_FIELD(mu));
}

/// event_t and event2_t (seq and sender after utime).
template <class M, class V>
void EventFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  if constexpr (field_detail::HasSeq<M>::value) v.Int("seq", "", ROCKLAB_FIELD(seq));
  if constexpr (field_detail::HasSender<M>::value) v.Text("sender", ROCKLAB_FIELD(sender));
  v.Text("source", ROCKLAB_FIELD(source));
  v.Int("kind", "", ROCKLAB_FIELD(kind));
  v.Real("value", "", ROCKLAB_FIELD(value));  // the unit depends on kind (event_t.lcm)
  v.Text("detail", ROCKLAB_FIELD(detail));
}

/// health_t and health2_t (seq and sender after utime).
template <class M, class V>
void HealthFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  if constexpr (field_detail::HasSeq<M>::value) v.Int("seq", "", ROCKLAB_FIELD(seq));
  if constexpr (field_detail::HasSender<M>::value) v.Text("sender", ROCKLAB_FIELD(sender));
  v.Text("node", ROCKLAB_FIELD(node));
  v.Text("state", ROCKLAB_FIELD(state));
  v.Real("rate_in_hz", "Hz", ROCKLAB_FIELD(rate_in_hz));
  v.Real("rate_out_hz", "Hz", ROCKLAB_FIELD(rate_out_hz));
  v.Int("count_in", "", ROCKLAB_FIELD(count_in));
  v.Int("count_out", "", ROCKLAB_FIELD(count_out));
  v.Int("dropped", "", ROCKLAB_FIELD(dropped));
  v.Int("gaps", "", ROCKLAB_FIELD(gaps));
  v.Int("bad_samples", "", ROCKLAB_FIELD(bad_samples));
  v.Real("lag_s", "s", ROCKLAB_FIELD(lag_s));
}

/// model_band_t.
template <class M, class V>
void ModelBandFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Text("name", ROCKLAB_FIELD(name));
  v.Text("model", ROCKLAB_FIELD(model));
  v.Int("draws", "", ROCKLAB_FIELD(draws));
  v.Int("members", "", ROCKLAB_FIELD(members));
  v.Real("noise_sigma", "rad", ROCKLAB_FIELD(noise_sigma));
  v.Real("theta_median", "rad", ROCKLAB_FIELD(theta_median));
  v.Real("theta_lo95", "rad", ROCKLAB_FIELD(theta_lo95));
  v.Real("theta_lo68", "rad", ROCKLAB_FIELD(theta_lo68));
  v.Real("theta_hi68", "rad", ROCKLAB_FIELD(theta_hi68));
  v.Real("theta_hi95", "rad", ROCKLAB_FIELD(theta_hi95));
  v.Int("impacts_up", "", ROCKLAB_FIELD(impacts_up));
  v.Real("impact_up_offset_sum", "s", ROCKLAB_FIELD(impact_up_offset_sum));
  v.Real("impact_up_offset_sq_sum", "s^2", ROCKLAB_FIELD(impact_up_offset_sq_sum));
  v.Int("impacts_down", "", ROCKLAB_FIELD(impacts_down));
  v.Real("impact_down_offset_sum", "s", ROCKLAB_FIELD(impact_down_offset_sum));
  v.Real("impact_down_offset_sq_sum", "s^2", ROCKLAB_FIELD(impact_down_offset_sq_sum));
}

/// band_comparison_t.
template <class M, class V>
void BandComparisonFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Text("name", ROCKLAB_FIELD(name));
  v.Real("window_s", "s", ROCKLAB_FIELD(window_s));
  v.Real("coverage95_window", "1", ROCKLAB_FIELD(coverage95_window));
  v.Real("coverage95_total", "1", ROCKLAB_FIELD(coverage95_total));
  v.Real("coverage68_window", "1", ROCKLAB_FIELD(coverage68_window));
  v.Real("coverage68_total", "1", ROCKLAB_FIELD(coverage68_total));
  v.Real("median_error", "rad", ROCKLAB_FIELD(median_error));
  v.Real("width95", "rad", ROCKLAB_FIELD(width95));
  v.Real("impact_timing_z", "1", ROCKLAB_FIELD(impact_timing_z));
  v.Real("impact_time_sd", "s", ROCKLAB_FIELD(impact_time_sd));
  v.Real("impact_timing_z_rms", "1", ROCKLAB_FIELD(impact_timing_z_rms));
  v.Int("matched_crossings", "", ROCKLAB_FIELD(matched_crossings));
  v.Int("unmatched_crossings", "", ROCKLAB_FIELD(unmatched_crossings));
  v.Int("valid", "", ROCKLAB_FIELD(valid));
  v.Int("samples", "", ROCKLAB_FIELD(samples));
  v.Int("valid_samples", "", ROCKLAB_FIELD(valid_samples));
}

/// raw_frame_t.
template <class M, class V>
void RawFrameFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Int("num_channels", "", ROCKLAB_FIELD(num_channels));
  v.Real("values", "", ROCKLAB_FIELD(values));  // raw units: RL_DAQ_CONFIG's gain and offset calibrate them
}

/// table_state_t.
template <class M, class V>
void TableStateFields(V& v) {
  v.Int("utime", "us", ROCKLAB_FIELD(utime));
  v.Int("seq", "", ROCKLAB_FIELD(seq));
  v.Real("displacement", "m", ROCKLAB_FIELD(displacement));
  v.Real("velocity", "m/s", ROCKLAB_FIELD(velocity));
  v.Real("acceleration", "m/s^2", ROCKLAB_FIELD(acceleration));
  v.Int("accel_source", "", ROCKLAB_FIELD(accel_source));
}

#undef ROCKLAB_FIELD

/// Copies each field a table lists from `in` to `out`: visit the table of
/// the type with fewer fields (In's for an upgrade); the fields only `Out`
/// has (seq, nbodies, ...) are the caller's. Types may differ: a scalar
/// into a per-body array becomes its only element. No allocation once
/// `out`'s strings and arrays have grown.
template <class In, class Out>
struct FieldCopier {
  const In& in;
  Out& out;
  template <class G>
  void Copy(G get) {
    auto& dst = get(out);
    const auto& src = get(in);
    using D = std::remove_reference_t<decltype(dst)>;
    using S = std::remove_cv_t<std::remove_reference_t<decltype(src)>>;
    if constexpr (kIsArray<D> && !kIsArray<S>) {
      dst.assign(1, static_cast<typename D::value_type>(src));
    } else if constexpr (std::is_same_v<std::remove_cv_t<D>, S>) {
      dst = src;  // an array or string keeps its storage
    } else {
      dst = static_cast<D>(src);
    }
  }
  template <class G>
  void Int(const char*, const char*, G get, unsigned = 0) { Copy(get); }
  template <class G>
  void Real(const char*, const char*, G get, unsigned = 0) { Copy(get); }
  template <class G>
  void Text(const char*, G get) { Copy(get); }
};

/// Copies a state with per-body values (`body_count` of them in
/// `bodies[k]`, daq::BlockState's) into a per-body type (block_state2_t):
/// visit the single-body table (block_state_t's); a field that is an array
/// in `Out` gets every body's value, a scalar (utime, seq) the state's.
/// nbodies is the caller's. No allocation once `out`'s arrays have grown.
template <class In, class Out>
struct BodiesCopier {
  const In& in;
  Out& out;
  template <class G>
  void Copy(G get) {
    auto& dst = get(out);
    using D = std::remove_reference_t<decltype(dst)>;
    if constexpr (kIsArray<D>) {
      dst.resize(static_cast<std::size_t>(in.body_count));
      for (std::size_t k = 0; k < dst.size(); ++k) {
        dst[k] = static_cast<typename D::value_type>(get(in.bodies[k]));
      }
    } else {
      dst = static_cast<D>(get(in));
    }
  }
  template <class G>
  void Int(const char*, const char*, G get, unsigned = 0) { Copy(get); }
  template <class G>
  void Real(const char*, const char*, G get, unsigned = 0) { Copy(get); }
};

}  // namespace rocklab::common
