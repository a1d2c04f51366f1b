// rocklab.reconstruct, fit, sweep and fragility: daq::Processor as `rocklab
// reconstruct` drives it, model/fit.h as `rocklab fit`, sweep::RunCase and
// FormatRow as `rocklab sweep` and sweep::FitFragilities as `sweep-plot`.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <pybind11/stl.h>

#include "common/field_tables.h"
#include "daq/processor.h"
#include "daq/source.h"
#include "model/fit.h"
#include "model/model_registry.h"
#include "model/posterior.h"
#include "model/test_record.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "python/bindings.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "sweep/fragility.h"
#include "sweep/plot.h"
#include "sweep/sweep.h"

namespace rocklab::python {
namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::vector<double> ToVector(const DoubleArray& a, const char* name) {
  if (a.ndim() != 1) throw std::invalid_argument(std::string(name) + " must be a 1-D array");
  return std::vector<double>(a.data(), a.data() + a.size());
}

// ---- reconstruct ----------------------------------------------------------

// The block states as columns (the CSV of `rocklab reconstruct`, and more):
// time, then the fields of common/field_tables.h's block state named in
// kOrder, each with the table's unit (a multi-body rig: the bottom body's,
// as RL_THETA), then for a multi-body rig the CSV's per-body columns
// (BodyColumns). A sink must not throw: the progress hook's exception is
// kept, and the read loop stops on it.
class ColumnSink final : public daq::ProcessorSink {
 public:
  // rocklab.reconstruct's dtype order (the Python contract, older than the
  // table; utime and seq are not columns).
  static constexpr std::array<const char*, 13> kOrder{
      "theta", "theta_dot", "theta_mirror", "theta_camera", "sliding", "twist", "out_of_plane",
      "jump", "tilt", "table_displacement", "table_acceleration", "flags", "leds_used"};
  struct Column {
    const char* unit{};
    bool integer{};
    std::vector<double> real;
    std::vector<std::int64_t> ints;
  };

  explicit ColumnSink(ProgressHook& hook) : hook_(hook) {
    Describe d{*this};
    VisitFields(d);
    for (std::size_t i = 0; i < kOrder.size(); ++i) {
      if (columns[i].unit == nullptr) throw std::logic_error(std::string("reconstruct: no field ") + kOrder[i]);
    }
  }
  // A rig of `count` >= 2 bodies: `rocklab reconstruct`'s per-body columns,
  // per body K = 1.. bottom-up every per-body field of block_state2_t
  // (block_state_t's table but utime and seq) suffixed _K, with its unit.
  void SetBodies(int count) {
    for (int k = 1; k <= count; ++k) {
      NameBodyColumns names{*this, "_" + std::to_string(k)};
      common::BlockStateFields<rocklab::block_state_t>(names);
    }
    per_body_ = body_columns.size() / static_cast<std::size_t>(std::max(count, 1));
  }
  void OnBlockState(const daq::BlockState& s) override {
    time.push_back(s.time_s);
    Append a{*this, s};
    VisitFields(a);
    if (!body_columns.empty()) {
      // Copied as the CLI and the DAQ copy them (BodiesCopier), then read per body.
      common::BodiesCopier<daq::BlockState, rocklab::block_state2_t> copy{s, bodies_msg_};
      common::BlockStateFields<rocklab::block_state_t>(copy);
      for (std::size_t k = 0; k < static_cast<std::size_t>(s.body_count); ++k) {
        AppendBody row{*this, k, k * per_body_};
        common::BlockStateFields<rocklab::block_state_t>(row);
      }
    }
    (void)hook_.Poll(s.time_s);
  }
  void OnEvent(const daq::DaqEvent& e) override { events.push_back(e); }
  void OnProblem(const daq::Problem& p) override { problems.push_back(daq::ToString(p)); }

  std::vector<double> time;
  std::array<Column, kOrder.size()> columns;  // in kOrder
  struct BodyColumn {
    std::string name;  ///< FIELD_K
    Column values;
  };
  std::vector<BodyColumn> body_columns;  // a multi-body rig's, body by body
  std::vector<daq::DaqEvent> events;
  std::vector<std::string> problems;

 private:
  template <class V>
  static void VisitFields(V& v) {
    common::BlockStateFields<daq::BlockState>(v);
    common::BlockStateExtraFields(v);
  }
  // Which column each field of the table goes to (-1: none), and the
  // columns' units and types.
  struct Describe {
    ColumnSink& sink;
    template <class G>
    void Int(const char* name, const char* unit, G, unsigned) { Add(name, unit, true); }
    template <class G>
    void Real(const char* name, const char* unit, G, unsigned) { Add(name, unit, false); }
    void Add(const char* name, const char* unit, bool integer) {
      int slot = -1;
      for (std::size_t i = 0; i < kOrder.size(); ++i) {
        if (std::string_view(kOrder[i]) == name) slot = static_cast<int>(i);
      }
      sink.slots_.push_back(slot);
      if (slot < 0) return;
      sink.columns[static_cast<std::size_t>(slot)].unit = unit;
      sink.columns[static_cast<std::size_t>(slot)].integer = integer;
    }
  };
  struct Append {
    ColumnSink& sink;
    const daq::BlockState& s;
    std::size_t field{0};
    template <class G>
    void Int(const char*, const char*, G get, unsigned) {
      if (const int slot = sink.slots_[field++]; slot >= 0) {
        sink.columns[static_cast<std::size_t>(slot)].ints.push_back(get(s));
      }
    }
    template <class G>
    void Real(const char*, const char*, G get, unsigned) {
      if (const int slot = sink.slots_[field++]; slot >= 0) {
        sink.columns[static_cast<std::size_t>(slot)].real.push_back(get(s));
      }
    }
  };
  struct NameBodyColumns {
    ColumnSink& sink;
    std::string suffix;
    template <class G>
    void Int(const char* name, const char* unit, G, unsigned) { Add(name, unit, true); }
    template <class G>
    void Real(const char* name, const char* unit, G, unsigned) { Add(name, unit, false); }
    void Add(const char* name, const char* unit, bool integer) {
      if (std::string_view(name) == "utime" || std::string_view(name) == "seq") return;
      BodyColumn c;
      c.name = name + suffix;
      c.values.unit = unit;
      c.values.integer = integer;
      sink.body_columns.push_back(std::move(c));
    }
  };
  // Body k's values of the copied message into its columns (from `at`).
  struct AppendBody {
    ColumnSink& sink;
    std::size_t k;
    std::size_t at;
    template <class G>
    void Int(const char*, const char*, G get, unsigned) {
      const auto& field = get(sink.bodies_msg_);
      if constexpr (common::kIsArray<decltype(field)>) sink.body_columns[at++].values.ints.push_back(field[k]);
    }
    template <class G>
    void Real(const char*, const char*, G get, unsigned) {
      const auto& field = get(sink.bodies_msg_);
      if constexpr (common::kIsArray<decltype(field)>) sink.body_columns[at++].values.real.push_back(field[k]);
    }
  };
  std::vector<int> slots_;  // per field of the table, in its order
  std::size_t per_body_{};  // body_columns of one body
  rocklab::block_state2_t bodies_msg_;  // a multi-body state, copied by the field table
  ProgressHook& hook_;
};

py::tuple Reconstruct(const std::string& input, const std::string& rig_path, const py::object& progress) {
  ProgressHook hook(progress, 0.0);
  ColumnSink sink(hook);
  daq::SourceStats src;
  daq::SequenceCounts seq;
  daq::ReconstructionCounts rec;
  daq::ProcessorCounts counts;
  std::string read_error;
  {
    py::gil_scoped_release release;
    RunStoppable(hook, [&] {
      daq::RigConfig rig;
      try {
        rig = pipeline::LoadRig(rig_path);
      } catch (const pipeline::OptionError& e) {
        ThrowIfUnreadable(rig_path, e.what());
        throw;
      }
      if (rig.multi_body()) sink.SetBodies(rig.body_count());
      daq::SourceOptions options;  // as `rocklab reconstruct`
      options.sample_rate_hz = rig.sample_rate_hz;
      for (const auto& c : rig.channels) options.fallback_channel_names.push_back(c.name);
      options.on_problem = [&sink](const daq::Problem& p) { sink.problems.push_back(daq::ToString(p)); };
      std::unique_ptr<daq::Source> source;
      std::unique_ptr<daq::Processor> processor;
      try {
        source = daq::OpenSource(input, options);
        processor = std::make_unique<daq::Processor>(rig, source->channel_names(), source->path(), sink);
      } catch (const std::exception& e) {
        ThrowIfUnreadable(input, std::string("--input: ") + e.what());
        throw pipeline::OptionError(std::string("--input: ") + e.what());
      }
      daq::Frame frame;
      daq::ReadStatus status{};
      while (!hook.stopped() && (status = source->Next(frame)) == daq::ReadStatus::kFrame) processor->Process(frame);
      hook.RethrowIfStopped();
      processor->Finish();
      if (status == daq::ReadStatus::kError) read_error = source->error();
      src = source->stats();
      seq = processor->sequence();
      rec = processor->reconstruction();
      counts = processor->counts();
    });
  }
  py::dict columns;
  columns["time"] = py::make_tuple(OwnedArray(std::move(sink.time)), "s");
  for (std::size_t i = 0; i < ColumnSink::kOrder.size(); ++i) {
    ColumnSink::Column& c = sink.columns[i];
    columns[ColumnSink::kOrder[i]] =
        c.integer ? py::make_tuple(OwnedArray(std::move(c.ints)), c.unit) : py::make_tuple(OwnedArray(std::move(c.real)), c.unit);
  }
  for (ColumnSink::BodyColumn& b : sink.body_columns) {
    ColumnSink::Column& c = b.values;
    columns[b.name.c_str()] =
        c.integer ? py::make_tuple(OwnedArray(std::move(c.ints)), c.unit) : py::make_tuple(OwnedArray(std::move(c.real)), c.unit);
  }
  py::list events;
  for (const daq::DaqEvent& e : sink.events) {
    events.append(py::make_tuple(static_cast<double>(e.utime) * 1e-6, static_cast<int>(e.kind), e.value, e.detail));
  }
  py::dict summary;
  summary["rows"] = src.rows;
  summary["bad_rows"] = src.bad_rows;
  summary["bad_values"] = src.bad_values;
  summary["gaps"] = seq.gaps;
  summary["missing"] = seq.missing;
  summary["duplicates"] = seq.duplicates;
  summary["out_of_order"] = seq.out_of_order;
  summary["invalid_led_samples"] = rec.invalid_led_samples;
  summary["reconstructed"] = counts.reconstructed;
  summary["flagged"] = counts.flagged;
  summary["damaged_regions"] = src.damaged_regions;
  summary["damaged_bytes"] = src.damaged_bytes;
  summary["damaged_events"] = src.damaged_events;
  summary["read_error"] = read_error;
  summary["problems"] = sink.problems;
  return py::make_tuple(columns, events, summary);
}

// ---- fit ------------------------------------------------------------------

py::object Optional(double v) { return std::isfinite(v) ? py::object(py::float_(v)) : py::none(); }
py::object Optional(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? py::object(py::float_(*v)) : py::none();
}

// The keys of `rocklab fit --json` (tools/cmd_fit.cpp), from the same FitResult.
py::dict FitDict(const std::string& input, const model::FitResult& r) {
  py::list impacts;
  for (const model::ImpactRow& row : r.impacts) {
    py::dict d;
    d["n"] = row.n;
    d["time"] = Optional(row.time_s);
    d["peak"] = Optional(row.peak_rad);
    d["mu_n"] = Optional(row.mu_n);
    d["tau"] = Optional(row.tau_s);
    d["residual"] = Optional(row.residual_s);
    d["residual_noise"] = Optional(row.noise_s);
    impacts.append(d);
  }
  const bool by_impacts = r.method == model::FitMethod::kImpacts;
  py::dict j;
  j["input"] = input;
  j["method"] = model::ToString(r.method);
  j["quarter_time"] = by_impacts ? py::object(py::str(model::ToString(r.quarter_time))) : py::none();
  j["alpha"] = r.params.alpha;
  j["p"] = r.params.p;
  j["mu"] = r.params.mu;
  j["mu_spread"] = Optional(r.mu_spread);
  j["alpha_stderr"] = Optional(r.alpha_stderr);
  j["p_stderr"] = Optional(r.p_stderr);
  j["mu_stderr"] = Optional(r.mu_stderr);
  j["alpha_p_correlation"] = Optional(r.alpha_p_correlation);
  j["rms_residual"] = r.rms_residual;
  j["residuals"] = r.residuals;
  j["iterations"] = r.iterations;
  j["evaluations"] = r.evaluations;
  j["runtime"] = r.runtime_s;
  j["forced"] = r.forced;
  j["noise"] = r.features.noise_rad;
  j["dof"] = r.dof;
  j["converged"] = r.converged;
  j["residual_to_noise"] = Optional(r.residual_to_noise);
  j["chi2"] = Optional(r.chi2);
  j["chi2_per_dof"] = Optional(r.chi2_per_dof);
  j["p_value"] = Optional(r.p_value);
  j["band_ratio"] = Optional(r.band_ratio);
  j["band_p_value"] = Optional(r.band_p_value);
  j["band_hz"] = Optional(r.band_hz);
  j["significance"] = r.significance;
  j["noise_dof"] = Optional(r.noise_dof);
  j["noise_stated"] = std::isinf(r.noise_dof);
  j["starts"] = r.starts;
  j["starts_refined"] = r.starts_refined;
  j["noise_residual"] = Optional(r.noise_residual);
  j["stderr_withheld"] = r.stderr_withheld;
  j["missing_samples"] = r.theta_gaps.missing_samples;
  j["gaps"] = r.theta_gaps.gaps;
  j["longest_gap"] = r.theta_gaps.longest_s;
  j["missing_table_samples"] = r.table_gaps.missing_samples;
  j["table_interpolation_error"] = Optional(r.table_interpolation_rad);
  j["table_reading"] = r.forced ? py::object(py::str(model::TableReadingName(r.table_interpolation))) : py::none();
  j["release_time"] = by_impacts ? Optional(r.features.release_time_s) : Optional(r.release_time_s);
  j["impacts"] = impacts;
  j["warnings"] = r.warnings;
  if (r.second_minimum) {
    py::dict m;
    m["alpha"] = r.second_minimum->params.alpha;
    m["p"] = r.second_minimum->params.p;
    m["mu"] = r.second_minimum->params.mu;
    m["delta_chi2"] = r.second_minimum->delta_chi2;
    j["second_minimum"] = m;
  } else {
    j["second_minimum"] = py::none();
  }
  if (r.theory) {
    py::dict t;
    t["alpha"] = r.theory->alpha;
    t["p"] = r.theory->p;
    t["mu"] = r.theory->mu;
    j["theory"] = t;
  } else {
    j["theory"] = py::none();
  }
  if (r.band) {
    py::dict b;
    b["lo"] = r.band->lo;
    b["hi"] = r.band->hi;
    b["band_m"] = r.band->band_m;
    j["alpha_band"] = b;
  } else {
    j["alpha_band"] = py::none();
  }
  return j;
}

// The options `rocklab fit` checks, in its order and words.
model::FitOptions FitOptionsOf(std::optional<double> width_m, std::optional<double> height_m, double chamfer_m,
                               const std::string& quarter_time, double alpha_band_m, int min_impacts) {
  model::FitOptions fo;
  try {
    fo.quarter_time = model::ParseQuarterTime(quarter_time);
  } catch (const std::invalid_argument&) {
    throw pipeline::OptionError("--quarter-time must be exact or slender, got '" + quarter_time + "'");
  }
  pipeline::Require(alpha_band_m >= 0.0, "--alpha-band-m", ">= 0 m", alpha_band_m);
  pipeline::Require(min_impacts >= 3, "--min-impacts", ">= 3", min_impacts);
  fo.alpha_band_m = alpha_band_m;
  fo.min_impacts = min_impacts;
  if (width_m || height_m) {
    const double w = width_m.value_or(0.0), h = height_m.value_or(0.0);
    pipeline::Require(w > 0.0, "--width", "> 0 m", w);
    pipeline::Require(h > 0.0, "--height", "> 0 m", h);
    pipeline::Require(chamfer_m >= 0.0, "--chamfer", ">= 0 m", chamfer_m);
    fo.geometry = model::FitGeometry{w, h, chamfer_m};
    try {
      (void)model::AdmissibleAlphaBand(*fo.geometry, fo.alpha_band_m);
    } catch (const std::invalid_argument& e) {
      throw pipeline::OptionError(std::string("geometry: ") + e.what());
    }
  }
  return fo;
}

model::FitMethod FitMethodOf(const std::string& method_name) {
  try {
    return model::ParseFitMethod(method_name);
  } catch (const std::invalid_argument&) {
    throw pipeline::OptionError("--method must be impacts or trajectory, got '" + method_name + "'");
  }
}

// The record of arrays t, theta (and the table's), read with the GIL held;
// empty (source "") when t is None.
model::RockingRecord RecordOfArrays(const std::optional<DoubleArray>& t, const std::optional<DoubleArray>& theta,
                                    const std::optional<DoubleArray>& table_t,
                                    const std::optional<DoubleArray>& table_a) {
  model::RockingRecord record;
  if (!t) return record;
  record.source = "<arrays>";
  record.time_s = ToVector(*t, "t");
  record.theta = ToVector(*theta, "theta");
  if (record.time_s.size() != record.theta.size()) {
    throw std::invalid_argument("t and theta must have the same length");
  }
  for (std::size_t i = 0; i < record.time_s.size(); ++i) record.line.push_back(static_cast<int64_t>(i) + 1);
  if (table_t) {
    record.table_time_s = ToVector(*table_t, "table t");
    record.table_accel_mps2 = ToVector(*table_a, "table a");
    if (record.table_time_s.size() != record.table_accel_mps2.size()) {
      throw std::invalid_argument("table: t and a must have the same length");
    }
  }
  return record;
}

// Reads `input` (no arrays) or checks the arrays' record, then adds the
// table of `accel_path`. Without the GIL. @throws model::RecordError.
void CompleteRecord(model::RockingRecord& record, bool from_arrays, const std::string& input,
                    const std::string& accel_path) {
  if (!from_arrays) {
    try {
      record = model::ReadRecord(input);
    } catch (const model::RecordError& e) {
      ThrowIfUnreadable(input, e.what());
      throw;
    }
  } else {
    model::CheckRecord(record);
    record.theta_gaps = model::CountGaps(record.time_s, record.line);
    if (record.has_table()) {
      std::vector<int64_t> lines;
      for (std::size_t i = 0; i < record.table_time_s.size(); ++i) lines.push_back(static_cast<int64_t>(i) + 1);
      record.table_gaps = model::CountGaps(record.table_time_s, lines);
    }
  }
  if (!accel_path.empty()) {
    try {
      model::AddTableCsv(accel_path, record);
    } catch (const model::RecordError& e) {
      ThrowIfUnreadable(accel_path, e.what());
      throw;
    }
  }
}

py::dict Fit(const std::string& input, std::optional<DoubleArray> t, std::optional<DoubleArray> theta,
             std::optional<DoubleArray> table_t, std::optional<DoubleArray> table_a, const std::string& accel_path,
             std::optional<double> width_m, std::optional<double> height_m, double chamfer_m,
             const std::string& method_name, const std::string& quarter_time, double alpha_band_m, int min_impacts,
             double start_s, double end_s, const py::object& progress) {
  try {
    model::RockingRecord none;
    model::WindowRecord(none, start_s, end_s);  // the window's own checks, before any read
  } catch (const std::invalid_argument& e) {
    throw pipeline::OptionError(e.what());
  }
  model::FitOptions fo = FitOptionsOf(width_m, height_m, chamfer_m, quarter_time, alpha_band_m, min_impacts);
  const model::FitMethod method = FitMethodOf(method_name);
  model::RockingRecord record = RecordOfArrays(t, theta, table_t, table_a);
  ProgressHook hook(progress, static_cast<double>(fo.max_evaluations));
  // The fit polls the hook on this thread (the GIL released), between its
  // iterations and model runs and along its scans (model/cancel.h): Ctrl-C
  // or the callback's exception stops it within about 0.1 s.
  fo.on_progress = [&hook](const model::FitProgress& p) { (void)hook.Poll(p.evaluations); };
  fo.cancelled = hook.Cancel();
  model::FitResult result;
  {
    py::gil_scoped_release release;
    try {
      result = RunStoppable(hook, [&] {
        CompleteRecord(record, t.has_value(), input, accel_path);
        model::WindowRecord(record, start_s, end_s);
        return method == model::FitMethod::kImpacts ? model::FitImpacts(record, fo) : model::FitTrajectory(record, fo);
      });
    } catch (const model::RecordError& e) {
      throw pipeline::OptionError(e.what());
    } catch (const model::FitError& e) {
      throw pipeline::OptionError(e.what());
    }
  }
  hook.RethrowIfStopped();
  return FitDict(t ? std::string("<arrays>") : input, result);
}

// ---- posterior ------------------------------------------------------------

// The options of `rocklab fit --posterior` from the Python arguments.
model::PosteriorOptions PosteriorOptionsOf(model::FitOptions fo, model::FitMethod method, const std::string& model_name,
                                           std::uint64_t seed, int walkers, int steps, int burn_in, int threads,
                                           double rtol, const std::string& integrator, const py::dict& priors) {
  model::PosteriorOptions po;
  if (!fo.geometry) throw pipeline::OptionError("--posterior needs the block geometry (width and height)");
  try {
    po.model = model::ParseModelKind(model_name);
  } catch (const std::invalid_argument&) {
    throw pipeline::OptionError("--model must be " + model::ModelNames(" or ") + ", got '" + model_name + "'");
  }
  if (integrator != "adams" && integrator != "rk") {
    throw pipeline::OptionError("--integrator must be adams or rk, got '" + integrator + "'");
  }
  if (po.model == model::ModelKind::kComplex && method != model::FitMethod::kTrajectory) {
    throw pipeline::OptionError("--model complex needs --method trajectory");
  }
  po.method = method;
  po.fit = fo;
  po.rtol = rtol;
  po.integrator = integrator == "rk" ? model::Integrator::kRungeKutta : model::Integrator::kAdams;
  po.sampler.seed = seed;
  po.sampler.walkers = walkers;
  po.sampler.steps = steps;
  po.sampler.threads = threads;
  po.burn_in = burn_in;
  po.priors.alpha_band_m = fo.alpha_band_m > 0.0 ? fo.alpha_band_m : po.priors.alpha_band_m;
  for (const auto& [key, value] : priors) {
    const std::string k = py::str(key);
    const double v = value.cast<double>();
    model::PosteriorPriors& pr = po.priors;
    if (k == "alpha_band_m") {
      pr.alpha_band_m = v;
    } else if (k == "p_range") {
      pr.p_range = v;
    } else if (k == "mu_min") {
      pr.mu_min = v;
    } else if (k == "mu_max") {
      pr.mu_max = v;
    } else if (k == "log10_l_min") {
      pr.log10_l_min = v;
    } else if (k == "log10_l_max") {
      pr.log10_l_max = v;
    } else if (k == "t_offset_s") {
      pr.t_offset_s = v;
    } else if (k == "sigma_mu_max") {  // as in the rig file: given, per-impact restitution is on
      pr.per_impact_mu = true;
      pr.sigma_mu_max = v;
    } else {
      throw pipeline::OptionError("priors: unknown key '" + k + "' (the rig file's [posterior] keys)");
    }
  }
  try {
    po.Validate();
  } catch (const std::invalid_argument& e) {
    throw pipeline::OptionError(e.what());
  }
  return po;
}

// A posterior problem of one record: its log posterior for other samplers
// (the emcee test), thread-safe, the GIL released while it runs the model.
class PyPosteriorProblem {
 public:
  PyPosteriorProblem(const model::RockingRecord& record, const model::PosteriorOptions& options)
      : options_(options), problem_(record, options) {
    options_.fit.cancelled = nullptr;  // the caller's hook, for the construction only
  }
  double LogPosterior(const DoubleArray& x) const {
    const std::vector<double> v = ToVector(x, "x");
    if (static_cast<int>(v.size()) != problem_.dimension()) {
      throw std::invalid_argument("x must have " + std::to_string(problem_.dimension()) + " entries (" +
                                  Join(problem_.names()) + ")");
    }
    const Eigen::VectorXd e = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
    // One model run over a long record takes seconds: Ctrl-C stops it.
    ProgressHook hook(py::none(), 0.0);
    double lp = 0.0;
    {
      py::gil_scoped_release release;
      const model::CancelToken token(hook.Cancel());
      try {
        lp = problem_.LogPosterior(e, token);
      } catch (const model::Cancelled&) {
        hook.RethrowIfStopped();
        throw;
      }
    }
    return lp;
  }
  const model::PosteriorProblem& problem() const { return problem_; }
  const model::PosteriorOptions& options() const { return options_; }
  static std::string Join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
    return out;
  }

 private:
  model::PosteriorOptions options_;
  model::PosteriorProblem problem_;
};

std::vector<double> ToStd(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

PyPosteriorProblem MakeProblem(const std::string& input, std::optional<DoubleArray> t, std::optional<DoubleArray> theta,
                               std::optional<DoubleArray> table_t, std::optional<DoubleArray> table_a,
                               const std::string& accel_path, std::optional<double> width_m,
                               std::optional<double> height_m, double chamfer_m, const std::string& method_name,
                               const std::string& quarter_time, double alpha_band_m, int min_impacts,
                               const std::string& model_name, std::uint64_t seed, int walkers, int steps, int burn_in,
                               int threads, double rtol, const std::string& integrator, const py::dict& priors) {
  const model::FitOptions fo = FitOptionsOf(width_m, height_m, chamfer_m, quarter_time, alpha_band_m, min_impacts);
  const model::FitMethod method = FitMethodOf(method_name);
  model::PosteriorOptions po =
      PosteriorOptionsOf(fo, method, model_name, seed, walkers, steps, burn_in, threads, rtol, integrator, priors);
  model::RockingRecord record = RecordOfArrays(t, theta, table_t, table_a);
  // Reading the record, the feature scan, the point fit and the start's
  // scan poll for signals (model/cancel.h, common/cancel.h).
  ProgressHook hook(py::none(), 0.0);
  po.fit.cancelled = hook.Cancel();
  py::gil_scoped_release release;
  try {
    return RunStoppable(hook, [&] {
      CompleteRecord(record, t.has_value(), input, accel_path);
      return PyPosteriorProblem(record, po);
    });
  } catch (const model::RecordError& e) {
    throw pipeline::OptionError(e.what());
  } catch (const model::FitError& e) {
    throw pipeline::OptionError(e.what());
  }
}

// The draws as columns and the summary as the JSON text of `fit --json`'s
// `posterior` (the Python side makes the structured array and the dict).
py::tuple SampleProblem(const PyPosteriorProblem& p, const py::object& progress) {
  model::PosteriorOptions po = p.options();
  ProgressHook hook(progress, static_cast<double>(po.sampler.steps));
  po.sampler.on_step = [&hook](int step, int) { (void)hook.Poll(step); };
  po.sampler.cancelled = hook.Cancel();  // after every step
  model::PosteriorResult r;
  {
    py::gil_scoped_release release;
    try {
      r = model::SamplePosterior(p.problem(), po);
    } catch (const model::Cancelled&) {
      hook.RethrowIfStopped();
      throw;
    } catch (const model::FitError& e) {
      throw pipeline::OptionError(e.what());
    }
  }
  hook.RethrowIfStopped();
  py::list columns;
  for (Eigen::Index c = 0; c < r.draws.cols(); ++c) columns.append(OwnedArray(ToStd(r.draws.col(c))));
  return py::make_tuple(r.names, columns, OwnedArray(ToStd(r.log_posterior)), model::PosteriorJson(r));
}

// ---- sweep ----------------------------------------------------------------

// The cases of a plan run on `threads` threads, rows formatted by
// sweep::FormatRow (the CSV of `rocklab sweep`, byte for byte).
std::string Sweep(const sweep::PlanOptions& options, unsigned threads, const py::object& progress) {
  ProgressHook hook(progress, 0.0);
  std::vector<std::string> rows;
  std::string csv;  // the definition and the header, then the rows
  {
    py::gil_scoped_release release;
    const sweep::Plan plan = RunStoppable(hook, [&] {
      try {
        return sweep::MakePlan(options);  // reads the records and the assembly
      } catch (const pipeline::OptionError& e) {
        if (!options.assembly.empty()) ThrowIfUnreadable(options.assembly, e.what());
        throw;
      }
    });
    csv = sweep::DefinitionText(sweep::DefinitionOf(plan)) + sweep::HeaderOf(plan) + "\n";
    hook.set_total(static_cast<double>(plan.size()));
    rows.resize(plan.size());
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    threads = static_cast<unsigned>(std::min<std::size_t>(threads, std::max<std::size_t>(plan.size(), 1)));
    std::atomic<std::size_t> next{0}, done{0};
    std::mutex error_mutex;
    std::exception_ptr error;
    // Workers take the next case; the first error (a failed case, or the
    // progress callback's exception) stops every worker after its case.
    // Ctrl-C stops them inside their cases: this thread polls the hook
    // (in its own cases, and every 10 ms once it waits), the others see
    // the token's flag every 256 samples.
    const common::CancelToken token(hook.Cancel());
    auto run = [&](int worker) {
      for (std::size_t i; (i = next.fetch_add(1)) < plan.size();) {
        try {
          rows[i] = sweep::FormatRow(plan, i, sweep::RunCase(plan, i, &token));
          const std::size_t n = ++done;
          if (worker == 0) hook.Update(static_cast<double>(n));
        } catch (...) {
          const std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
          next = plan.size();
        }
      }
    };
    common::RunOnThreads(static_cast<int>(threads), token, run);  // this thread works too
    hook.RethrowIfStopped();
    if (error) std::rethrow_exception(error);
    hook.Done(static_cast<double>(plan.size()));
  }
  for (const std::string& row : rows) csv += row;
  return csv;
}

// ---- fragility ------------------------------------------------------------

py::dict FragilityDict(const sweep::FragilityFit& f) {
  py::dict d;
  d["status"] = sweep::ToString(f.status);
  const bool fitted = f.status == sweep::FragilityFit::Status::kFitted;
  const bool separated = f.status == sweep::FragilityFit::Status::kSeparated;
  d["median"] = fitted ? py::object(py::float_(f.median)) : py::none();
  d["beta"] = fitted ? py::object(py::float_(f.beta)) : py::none();
  d["log_likelihood"] = fitted ? py::object(py::float_(f.log_likelihood)) : py::none();
  d["safe_below"] = separated ? py::object(py::float_(f.safe_below)) : py::none();
  d["overturned_above"] = separated ? py::object(py::float_(f.overturned_above)) : py::none();
  d["iterations"] = f.iterations;
  return d;
}

py::dict Fragility(const DoubleArray& x, const DoubleArray& overturned, const DoubleArray& trials) {
  const std::vector<double> xs = ToVector(x, "x"), ks = ToVector(overturned, "overturned"),
                            ns = ToVector(trials, "trials");
  if (xs.size() != ks.size() || xs.size() != ns.size()) {
    throw std::invalid_argument("x, overturned and trials must have the same length");
  }
  std::vector<sweep::FragilityPoint> points;
  for (std::size_t i = 0; i < xs.size(); ++i) points.push_back({xs[i], ns[i], ks[i]});
  return FragilityDict(sweep::FitLognormalFragility(points));
}

// The fragility of every block of a sweep's results, as `sweep-plot` fits
// them (grouped by model and the block's alpha, p, mu as written).
py::list SweepFragilities(const std::vector<std::string>& model, const std::vector<std::string>& alpha,
                          const std::vector<std::string>& p, const std::vector<std::string>& mu,
                          const DoubleArray& pga_g, const DoubleArray& peak, const std::vector<bool>& overturned) {
  std::vector<sweep::ResultRow> rows(model.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    sweep::ResultRow& r = rows[i];
    r.model = model[i];
    r.alpha_text = alpha[i];
    r.p_text = p[i];
    r.mu_text = mu[i];
    r.pga_g = pga_g.at(static_cast<py::ssize_t>(i));
    r.peak_theta_over_alpha = peak.at(static_cast<py::ssize_t>(i));
    r.overturned = overturned[i];
  }
  py::list out;
  for (const sweep::BlockFragility& f : sweep::FitFragilities(rows)) {
    py::dict d = FragilityDict(f.fit);
    d["model"] = f.model;
    d["alpha"] = f.alpha;
    d["p"] = f.p;
    d["mu"] = f.mu;
    d["rows"] = f.rows;
    d["overturned"] = f.overturned;
    out.append(d);
  }
  return out;
}

}  // namespace

void RegisterAnalysis(py::module_& m) {
  m.def("_reconstruct", &Reconstruct, py::arg("input"), py::arg("rig"), py::arg("progress"));
  py::class_<PyPosteriorProblem>(m, "_PosteriorProblem")
      .def("log_posterior", &PyPosteriorProblem::LogPosterior, py::arg("x"))
      .def_property_readonly("names", [](const PyPosteriorProblem& p) { return p.problem().names(); })
      .def_property_readonly("lower", [](const PyPosteriorProblem& p) { return ToStd(p.problem().lower()); })
      .def_property_readonly("upper", [](const PyPosteriorProblem& p) { return ToStd(p.problem().upper()); })
      .def("start", [](const PyPosteriorProblem& p) { return ToStd(p.problem().Start()); })
      .def("start_scale", [](const PyPosteriorProblem& p) { return ToStd(p.problem().StartScale()); })
      .def("to_reported",
           [](const PyPosteriorProblem& p, const DoubleArray& x) {
             const std::vector<double> v = ToVector(x, "x");
             return ToStd(p.problem().ToReported(
                 Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()))));
           },
           py::arg("x"));
  m.def("_posterior_problem", &MakeProblem, py::arg("input"), py::arg("t"), py::arg("theta"), py::arg("table_t"),
        py::arg("table_a"), py::arg("accel"), py::arg("width"), py::arg("height"), py::arg("chamfer"),
        py::arg("method"), py::arg("quarter_time"), py::arg("alpha_band"), py::arg("min_impacts"), py::arg("model"),
        py::arg("seed"), py::arg("walkers"), py::arg("steps"), py::arg("burn_in"), py::arg("threads"),
        py::arg("rtol"), py::arg("integrator"), py::arg("priors"));
  m.def("_sample_posterior", &SampleProblem, py::arg("problem"), py::arg("progress"));
  m.def("_fit", &Fit, py::arg("input"), py::arg("t"), py::arg("theta"), py::arg("table_t"), py::arg("table_a"),
        py::arg("accel"), py::arg("width"), py::arg("height"), py::arg("chamfer"), py::arg("method"),
        py::arg("quarter_time"), py::arg("alpha_band"), py::arg("min_impacts"), py::arg("start"), py::arg("end"),
        py::arg("progress"));
  m.def(
      "_sweep",
      [](const std::vector<std::string>& records, const std::string& scale, bool pga_g,
         const std::vector<double>& alpha, const std::vector<double>& p, const std::vector<double>& mu,
         const std::vector<double>& width, const std::vector<double>& height,
         const std::vector<std::string>& polygons, const std::string& assembly, const std::string& model,
         std::optional<double> duration, double rate, double l, std::optional<double> rtol, unsigned threads,
         const py::object& progress) {
        sweep::PlanOptions o;
        o.records = records;
        o.scale = scale;
        o.pga_g = pga_g;
        o.alpha = alpha;
        o.p = p;
        o.mu = mu;
        o.width = width;
        o.height = height;
        o.polygons = polygons;
        o.assembly = assembly;  // "": none (sweep::PlanOptions' default)
        o.model = model;
        o.duration_s = duration;
        o.rate_hz = rate;
        o.l = l;
        if (rtol) o.rtol = *rtol;
        return Sweep(o, threads, progress);
      },
      py::arg("records"), py::arg("scale"), py::arg("pga_g"), py::arg("alpha"), py::arg("p"), py::arg("mu"),
      py::arg("width"), py::arg("height"), py::arg("polygons"), py::arg("assembly"), py::arg("model"),
      py::arg("duration"),
      py::arg("rate"), py::arg("l"), py::arg("rtol"), py::arg("threads"), py::arg("progress"));
  m.def("_fragility", &Fragility, py::arg("x"), py::arg("overturned"), py::arg("trials"));
  m.def("_sweep_fragilities", &SweepFragilities, py::arg("model"), py::arg("alpha"), py::arg("p"), py::arg("mu"),
        py::arg("pga_g"), py::arg("peak"), py::arg("overturned"));
}

}  // namespace rocklab::python
