// rocklab.block_params and rocklab.simulate: model/block.h and
// pipeline/scenario.h (pipeline/assembly.h for an assembly) as `rocklab
// params` and `rocklab simulate` call them.
#include <cmath>
#include <ctime>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "model/block.h"
#include "model/excitation.h"
#include "model/rocking_model.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "pipeline/scenario.h"
#include "python/bindings.h"

namespace rocklab::python {
namespace {

py::dict SideDict(const model::SideGeometry& s) {
  py::dict d;
  d["alpha"] = s.alpha;
  d["R"] = s.R;
  d["p"] = s.p;
  d["mu"] = s.mu;
  d["I_O_per_mass"] = s.i_o_per_area;
  d["pivot"] = py::make_tuple(s.pivot_m.x(), s.pivot_m.y());
  return d;
}

// The keys of `rocklab params --json` (tools/cmd_params.cpp), from the
// same BlockGeometry.
py::dict GeometryDict(const model::BlockGeometry& g, double width_m, double height_m,
                      std::optional<double> chamfer_m, const std::optional<std::string>& polygon,
                      std::optional<std::size_t> vertices) {
  py::dict d;
  d["width"] = width_m;
  d["height"] = height_m;
  d["chamfer"] = chamfer_m ? py::object(py::float_(*chamfer_m)) : py::none();
  d["alpha"] = g.alpha;
  d["p"] = g.p;
  d["mu"] = g.mu_general;
  d["mu_housner"] = g.mu_housner;
  d["mu_general"] = g.mu_general;
  d["R"] = g.R;
  d["I_O_per_mass"] = g.i_o_per_area;
  d["g"] = model::kGravity;
  d["polygon"] = polygon ? py::object(py::str(*polygon)) : py::none();
  d["vertices"] = vertices ? py::object(py::int_(*vertices)) : py::none();
  d["area"] = g.area;
  d["I_G_per_mass"] = g.i_g_per_area;
  d["centroid"] = py::make_tuple(g.centroid_m.x(), g.centroid_m.y());
  d["symmetric"] = g.symmetric;
  d["plus_side"] = SideDict(g.plus);
  d["minus_side"] = SideDict(g.minus);
  return d;
}

py::dict RectangleParams(double width_m, double height_m, double chamfer_m) {
  pipeline::Require(std::isfinite(width_m) && width_m > 0, "--width", "> 0 m", width_m);
  pipeline::Require(std::isfinite(height_m) && height_m > 0, "--height", "> 0 m", height_m);
  pipeline::Require(std::isfinite(chamfer_m) && chamfer_m >= 0 &&
                        chamfer_m < 0.5 * std::min(width_m, height_m),
                    "--chamfer", ">= 0 m and below half the width and half the height", chamfer_m);
  return GeometryDict(model::RectangleBlock(width_m, height_m, chamfer_m), width_m, height_m,
                      chamfer_m, std::nullopt, std::nullopt);
}

// The section of `file` (read by the caller) as `rocklab params --polygon
// --json` gives it; the O(n log n) checks and the moments run without the GIL.
py::dict PolygonParams(const model::PolygonFile& file, const std::optional<std::string>& path) {
  model::BlockGeometry g;
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, z0 = HUGE_VAL, z1 = -HUGE_VAL;
  {
    py::gil_scoped_release release;
    g = model::PolygonBlock(file);
    for (const auto& v : file.vertices_m) {
      x0 = std::min(x0, v.x());
      x1 = std::max(x1, v.x());
      z0 = std::min(z0, v.y());
      z1 = std::max(z1, v.y());
    }
  }
  return GeometryDict(g, x1 - x0, z1 - z0, std::nullopt, path, file.vertices_m.size());
}

py::dict PolygonFileParams(const std::string& path) {
  model::PolygonFile file;
  ProgressHook hook(py::none(), 0.0);  // Ctrl-C
  try {
    py::gil_scoped_release release;
    file = RunStoppable(hook, [&] { return model::ReadPolygonCsv(path); });
  } catch (const std::invalid_argument& e) {
    ThrowIfUnreadable(path, e.what());
    throw;
  }
  return PolygonParams(file, path);
}

py::dict PolygonArrayParams(const py::array_t<double, py::array::c_style | py::array::forcecast>& xz) {
  if (xz.ndim() != 2 || xz.shape(1) != 2) {
    throw std::invalid_argument("polygon must be an (N, 2) array of x, z vertices, m");
  }
  model::PolygonFile file;
  const auto a = xz.unchecked<2>();
  file.vertices_m.reserve(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    file.vertices_m.emplace_back(a(i, 0), a(i, 1));
    file.line.push_back(static_cast<int>(i) + 1);
  }
  return PolygonParams(file, std::nullopt);
}

// One output row per sample, owned by numpy afterwards.
struct Samples {
  std::vector<double> t, theta, theta_dot;
};

py::object Summary(const pipeline::ScenarioOptions& o, const pipeline::Scenario& s,
                   const pipeline::RunSummary& r, double cpu_s) {
  const model::SolverStats stats = s.model->solver_stats();
  auto optional = [](const std::optional<double>& v) { return v ? py::object(py::float_(*v)) : py::none(); };
  const bool complex = o.model == "complex";
  py::dict d;  // the keys and order of `rocklab simulate --json` (tools/cmd_simulate.cpp)
  d["model"] = o.model;
  d["alpha"] = o.alpha;
  d["p"] = o.p;
  d["mu"] = o.mu;
  d["l"] = complex ? py::object(py::float_(o.l)) : py::none();
  d["theta0"] = o.theta0;
  d["excitation"] = s.forcing_description;
  d["duration"] = o.duration_s;
  d["rate"] = o.rate_hz;
  d["samples"] = r.samples;
  d["uplift_time"] = optional(r.uplift_time_s);
  d["peak_abs_theta"] = r.peak_abs_theta;
  d["peak_time"] = r.peak_time_s;
  d["impacts"] = r.impacts;
  d["overturned"] = r.overturned;
  d["overturn_time"] = optional(r.overturn_time_s);
  d["final_regime"] = model::ToString(s.model->state().regime);
  d["complex_handoff"] = complex ? py::object(py::float_(o.complex_handoff)) : py::none();
  d["eq10_fraction"] = stats.eq10_fraction;
  d["rocking_time"] = stats.rocking_time_s;
  d["steps"] = stats.steps;
  d["rhs_evals"] = stats.rhs_evals;
  d["error_test_fails"] = stats.error_test_fails;
  d["restarts"] = stats.restarts;
  d["recoveries"] = stats.recoveries;
  d["cpu_time"] = cpu_s;
  return std::move(d);
}

// The model's events as columns: time (s), kind, value (ModelEvent::value:
// uplift: table acceleration, m/s^2; impact: theta_dot just before, rad/s;
// rest: 0; overturn: theta, rad), theta_dot_after (impact: just after,
// rad/s; NaN otherwise).
py::dict EventColumns(const std::vector<model::ModelEvent>& events) {
  std::vector<double> time, value, after;
  py::list kind;
  for (const model::ModelEvent& e : events) {
    time.push_back(e.time_s);
    value.push_back(e.value);
    after.push_back(e.value_after);
    kind.append(model::ToString(e.kind));
  }
  py::dict d;
  d["time"] = OwnedArray(std::move(time));
  d["kind"] = kind;
  d["value"] = OwnedArray(std::move(value));
  d["theta_dot_after"] = OwnedArray(std::move(after));
  return d;
}

// The options a block's and an assembly's run share.
pipeline::ScenarioOptions RunOptionsOf(const std::string& model_name, const std::vector<std::string>& excitations,
                                       const std::string& accel_path, double duration_s, double rate_hz, double l,
                                       double complex_handoff, std::optional<double> rtol) {
  pipeline::ScenarioOptions o;
  o.model = model_name;
  o.excitations = excitations;
  o.accel_csv = accel_path;
  o.duration_s = duration_s;
  o.rate_hz = rate_hz;
  o.l = l;
  o.complex_handoff = complex_handoff;
  if (rtol) o.rtol = *rtol;  // else the model's default, as without --rtol
  return o;
}

py::dict Simulate(const std::string& model_name, double alpha, double p, double mu,
                  const std::vector<std::string>& excitations, const std::string& accel_path,
                  std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> accel_t,
                  std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> accel_a,
                  double theta0, double duration_s, double rate_hz, double l, double complex_handoff,
                  std::optional<double> rtol, const py::object& progress) {
  pipeline::ScenarioOptions o =
      RunOptionsOf(model_name, excitations, accel_path, duration_s, rate_hz, l, complex_handoff, rtol);
  o.alpha = alpha;
  o.p = p;
  o.mu = mu;
  o.theta0 = theta0;

  std::unique_ptr<model::Forcing> sampled;
  std::string sampled_what;
  if (accel_t || accel_a) {
    if (!accel_t || !accel_a || accel_t->ndim() != 1 || accel_a->ndim() != 1) {
      throw std::invalid_argument("accel must be a path or a pair (t, a) of 1-D arrays (s, m/s^2)");
    }
    const double* t = accel_t->data();
    const double* a = accel_a->data();
    // SampledAcceleration checks sizes, order and finiteness, naming the index.
    try {
      sampled = std::make_unique<model::SampledAcceleration>(
          std::vector<double>(t, t + accel_t->size()), std::vector<double>(a, a + accel_a->size()));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("accel: ") + e.what());
    }
    sampled_what = "accel:array(" + std::to_string(accel_t->size()) + " samples)";
  }

  pipeline::Scenario s;
  Samples out;
  pipeline::RunSummary r;
  double cpu_s = 0;
  {
    ProgressHook hook(progress, o.duration_s);
    py::gil_scoped_release release;
    try {
      s = RunStoppable(hook, [&] { return pipeline::BuildScenario(o); });  // reads --accel
    } catch (const pipeline::OptionError& e) {
      if (!o.accel_csv.empty()) ThrowIfUnreadable(o.accel_csv, e.what());
      throw;
    }
    if (sampled) {
      // As BuildScenario sums --excitation and --accel: the record after the excitations.
      std::vector<std::unique_ptr<model::Forcing>> parts;
      if (!o.excitations.empty() || !o.accel_csv.empty()) parts.push_back(std::move(s.forcing));
      parts.push_back(std::move(sampled));
      s.forcing = parts.size() == 1 ? std::move(parts.front()) : model::MakeForcingSum(std::move(parts));
      s.forcing_description = o.excitations.empty() && o.accel_csv.empty()
                                  ? sampled_what
                                  : s.forcing_description + " + " + sampled_what;
    }
    const auto rows = static_cast<std::size_t>(std::floor(o.duration_s * o.rate_hz + 1e-9)) + 1;
    out.t.reserve(rows);
    out.theta.reserve(rows);
    out.theta_dot.reserve(rows);
    const std::clock_t cpu0 = std::clock();
    r = pipeline::RunScenario(s, o, [&](double t, double theta, double theta_dot) {
      out.t.push_back(t);
      out.theta.push_back(theta);
      out.theta_dot.push_back(theta_dot);
      hook.Update(t);
    });
    cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    hook.Done(o.duration_s);
  }
  py::dict result;
  result["t"] = OwnedArray(std::move(out.t));
  result["theta"] = OwnedArray(std::move(out.theta));
  result["theta_dot"] = OwnedArray(std::move(out.theta_dot));
  result["events"] = EventColumns(s.model->events());
  result["summary"] = Summary(o, s, r, cpu_s);
  return result;
}

// An assembly (a file's path, or TOML text that Python made of a dict)
// run as `simulate --assembly`: per body arrays bottom-up, the mode per
// sample, the events naming interface and body, the summary's JSON text.
py::dict SimulateAssembly(const std::string& path, const std::string& text, const std::string& model_name,
                          const std::vector<std::string>& excitations, const std::string& accel_path,
                          double duration_s, double rate_hz, double l, double complex_handoff,
                          std::optional<double> rtol) {
  const pipeline::ScenarioOptions o =
      RunOptionsOf(model_name, excitations, accel_path, duration_s, rate_hz, l, complex_handoff, rtol);
  pipeline::AssemblyRun run;
  std::string summary;
  {
    py::gil_scoped_release release;
    pipeline::Assembly assembly;
    try {
      assembly = path.empty() ? pipeline::ParseAssembly(text, "assembly") : pipeline::ReadAssembly(path);
    } catch (const pipeline::OptionError& e) {
      if (!path.empty()) ThrowIfUnreadable(path, e.what());
      throw;
    }
    const std::clock_t cpu0 = std::clock();
    try {
      run = pipeline::RunAssembly(assembly, o);
    } catch (const pipeline::OptionError& e) {
      if (!o.accel_csv.empty()) ThrowIfUnreadable(o.accel_csv, e.what());
      throw;
    }
    const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    summary = pipeline::AssemblySummaryJson(o, assembly.path, run, pipeline::Summarise(run), cpu_s);
  }
  py::list theta, theta_dot;
  for (std::size_t k = 0; k < run.names.size(); ++k) {
    theta.append(OwnedArray(std::move(run.theta[k])));
    theta_dot.append(OwnedArray(std::move(run.theta_dot[k])));
  }
  std::vector<double> time;
  std::vector<int> interface;
  py::list kind, body, mode;
  for (const pipeline::AssemblyEvent& e : run.events) {
    time.push_back(e.time_s);
    interface.push_back(e.interface);
    kind.append(model::ToString(e.kind));
    body.append(run.names[static_cast<std::size_t>(e.interface)]);
    mode.append(e.mode);
  }
  py::dict events;
  events["time"] = OwnedArray(std::move(time));
  events["kind"] = kind;
  events["interface"] = OwnedArray(std::move(interface));
  events["body"] = body;
  events["mode"] = mode;
  py::dict result;
  result["t"] = OwnedArray(std::move(run.time_s));
  result["theta"] = theta;
  result["theta_dot"] = theta_dot;
  result["names"] = run.names;
  result["mode"] = run.mode;
  result["events"] = events;
  result["summary"] = summary;
  return result;
}

}  // namespace

void RegisterModel(py::module_& m) {
  m.def("_rectangle_params", &RectangleParams, py::arg("width"), py::arg("height"),
        py::arg("chamfer") = 0.0);
  m.def("_polygon_file_params", &PolygonFileParams, py::arg("path"));
  m.def("_polygon_array_params", &PolygonArrayParams, py::arg("vertices"));
  m.def("_simulate", &Simulate, py::arg("model"), py::arg("alpha"), py::arg("p"), py::arg("mu"),
        py::arg("excitations"), py::arg("accel_path"), py::arg("accel_t"), py::arg("accel_a"),
        py::arg("theta0"), py::arg("duration"), py::arg("rate"), py::arg("l"),
        py::arg("complex_handoff"), py::arg("rtol"), py::arg("progress"));
  m.def("_simulate_assembly", &SimulateAssembly, py::arg("path"), py::arg("text"), py::arg("model"),
        py::arg("excitations"), py::arg("accel_path"), py::arg("duration"), py::arg("rate"), py::arg("l"),
        py::arg("complex_handoff"), py::arg("rtol"));
  m.attr("DEFAULT_L") = model::kDefaultL;
  m.attr("GRAVITY") = model::kGravity;
}

}  // namespace rocklab::python
