#include "pipeline/scenario.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "common/units.h"
#include "model/model_registry.h"
#include "pipeline/option_error.h"

namespace rocklab::pipeline {

using common::kPi;

std::unique_ptr<model::Forcing> BuildForcing(const ScenarioOptions& o, std::string& description) {
  description.clear();
  std::vector<std::unique_ptr<model::Excitation>> parts;
  for (const std::string& spec : o.excitations) {
    try {
      parts.push_back(model::ParseExcitation(spec));
    } catch (const std::invalid_argument& e) {
      throw OptionError(std::string("--excitation: ") + e.what());
    }
    description += (description.empty() ? "" : " + ") + spec;
  }
  std::unique_ptr<model::Forcing> forcing;
  if (!parts.empty()) {
    forcing = parts.size() == 1 ? std::move(parts.front()) : model::MakeSum(std::move(parts));
  }
  if (!o.accel_csv.empty()) {
    std::unique_ptr<model::Forcing> record;
    try {
      record = std::make_unique<model::SampledAcceleration>(
          model::ReadAccelerationCsv(o.accel_csv));
    } catch (const std::exception& e) {
      throw OptionError(std::string("--accel: ") + e.what());
    }
    if (forcing) {
      std::vector<std::unique_ptr<model::Forcing>> both;
      both.push_back(std::move(forcing));
      both.push_back(std::move(record));
      forcing = model::MakeForcingSum(std::move(both));
    } else {
      forcing = std::move(record);
    }
    description += (description.empty() ? "" : " + ") + std::string("accel:") + o.accel_csv;
  }
  if (!forcing) {
    forcing = std::make_unique<model::NoTableMotion>();
    description = "none (free rocking)";
  }
  return forcing;
}

Scenario BuildScenario(const ScenarioOptions& o) {
  model::ModelKind kind{};
  try {
    kind = model::ParseModelKind(o.model);
  } catch (const std::invalid_argument&) {
    throw OptionError("--model must be " + model::ModelNames(" or ") + ", got '" + o.model + "'");
  }
  Require(std::isfinite(o.alpha) && o.alpha > 0 && o.alpha < kPi / 2, "--alpha",
          "in (0, pi/2) rad", o.alpha);
  Require(std::isfinite(o.p) && o.p > 0, "--p", "> 0 rad/s", o.p);
  Require(std::isfinite(o.mu) && o.mu > 0 && o.mu <= 1, "--mu", "in (0, 1]", o.mu);
  Require(std::isfinite(o.theta0) && std::abs(o.theta0) < kPi / 2, "--theta0",
          "in (-pi/2, pi/2) rad", o.theta0);
  Require(std::isfinite(o.duration_s) && o.duration_s >= 0, "--duration", ">= 0 s",
          o.duration_s);
  Require(std::isfinite(o.rate_hz) && o.rate_hz > 0, "--rate", "> 0 Hz", o.rate_hz);
  Require(std::isfinite(o.l) && o.l > 0, "--l", "> 0", o.l);
  Require(std::isfinite(o.rtol) && o.rtol > 0 && o.rtol <= 1e-3, "--rtol", "in (0, 1e-3]", o.rtol);
  Require(std::isfinite(o.complex_handoff) && o.complex_handoff >= 0, "--complex-handoff", ">= 0",
          o.complex_handoff);
  Require(o.duration_s * o.rate_hz < 1e9, "--duration", "such that duration * rate < 1e9 rows",
          o.duration_s);

  Scenario s;
  s.forcing = BuildForcing(o, s.forcing_description);

  model::ModelOptions mo;
  mo.l = o.l;
  mo.rtol = o.rtol;
  mo.complex_resolved_energy = o.complex_handoff;
  // The model's own integrator of a whole record (model_registry.cpp).
  mo.integrator = model::FindModel(kind).batch_integrator;
  s.model = model::RockingModel::Create(kind, {o.alpha, o.p, o.mu}, mo);
  return s;
}

RunSummary RunScenario(Scenario& s, const ScenarioOptions& o,
                       const std::function<void(double, double, double)>& on_sample) {
  RunSummary summary;
  model::RockingModel& m = *s.model;
  m.Reset(0.0, o.theta0, 0.0);
  const auto rows = static_cast<std::size_t>(std::floor(o.duration_s * o.rate_hz + 1e-9)) + 1;
  for (std::size_t k = 0; k < rows; ++k) {
    const double t = static_cast<double>(k) / o.rate_hz;
    // The forcing is known everywhere: no stop at the outputs (interpolated).
    if (k > 0) m.AdvanceAhead(t, *s.forcing, std::numeric_limits<double>::infinity());
    const model::ModelState& st = m.state();
    if (std::abs(st.theta) > summary.peak_abs_theta) {
      summary.peak_abs_theta = std::abs(st.theta);
      summary.peak_time_s = t;
    }
    on_sample(t, st.theta, st.theta_dot);
    ++summary.samples;
  }
  for (const model::ModelEvent& e : m.events()) {
    switch (e.kind) {
      case model::EventKind::kUplift:
        if (!summary.uplift_time_s) summary.uplift_time_s = e.time_s;
        break;
      case model::EventKind::kImpact:
        ++summary.impacts;
        break;
      case model::EventKind::kOverturn:
        summary.overturned = true;
        summary.overturn_time_s = e.time_s;
        break;
      case model::EventKind::kRest:
        break;
    }
  }
  return summary;
}

OutputFile::OutputFile(const std::string& path) {
  if (path == "-") {
    file_ = stdout;
    return;
  }
  try {
    out_ = std::make_unique<common::AtomicFile>(path);
  } catch (const std::runtime_error& e) {
    throw OptionError(e.what());
  }
  file_ = out_->stream();
}

void OutputFile::Close() {
  if (!out_) {
    if (file_ != nullptr && (std::fflush(file_) != 0 || std::ferror(file_) != 0)) {
      file_ = nullptr;
      throw std::runtime_error("cannot write to standard output (--out -)");
    }
    file_ = nullptr;
    return;
  }
  if (out_->committed()) return;
  file_ = nullptr;
  out_->Commit();
}

void WriteEventsCsv(const std::string& path, const std::vector<model::ModelEvent>& events) {
  OutputFile out(path);
  std::fprintf(out.get(), "time,kind\n");
  for (const model::ModelEvent& e : events) {
    std::fprintf(out.get(), "%.9f,%s\n", e.time_s, model::ToString(e.kind));
  }
  out.Close();
}

}  // namespace rocklab::pipeline
