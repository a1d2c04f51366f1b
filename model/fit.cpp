#include "model/fit.h"

#include <algorithm>
#include <cmath>

#include "model/block.h"
#include "model/fit_impl.h"
#include "model/free_rocking.h"

namespace rocklab::model {
namespace {

using fit_detail::Num;

// Theory and admissible band from the geometry, when there is one.
void SetGeometry(const FitOptions& options, FitResult& out) {
  if (!options.geometry) return;
  const FitGeometry& g = *options.geometry;
  out.theory = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).params();
  out.band = AdmissibleAlphaBand(g, options.alpha_band_m);
}

// Never rocks / overturns: the checks both methods share.
void CheckRocks(const RockingRecord& record, const FreeRockingFeatures& f, const FitResult& out,
                const FitOptions& options) {
  const double limit = out.band ? out.band->hi : options.features.overturn_rad;
  if (f.max_abs_theta > limit) {
    throw FitError(record.source + ": the block overturns (|theta| reaches " + Num(f.max_abs_theta, 4) +
                   " rad at " + Num(f.max_abs_theta_time_s, 5) + " s, beyond " +
                   (out.band ? "the admissible alpha " : "") + Num(limit, 4) +
                   " rad): there is no rocking response to fit");
  }
  if (f.max_abs_theta < f.min_peak_rad || (f.impact_time_s.empty() && f.peak_rad.empty())) {
    throw FitError(record.source + ": the block never rocks (max |theta| " + Num(f.max_abs_theta, 3) +
                   " rad, " + std::to_string(f.impact_time_s.size()) +
                   " zero crossings beyond the noise, estimated noise " + Num(f.noise_rad, 3) + " rad)");
  }
}

}  // namespace

namespace fit_detail {

double MaxAbsTable(const RockingRecord& r) {
  double m = 0.0;
  for (double a : r.table_accel_mps2) m = std::max(m, std::abs(a));
  return m;
}

FitResult StartFit(FitMethod method, const RockingRecord& record, const FitOptions& options) {
  options.Validate();
  FitResult out;
  out.method = method;
  out.quarter_time = options.quarter_time;
  SetGeometry(options, out);
  out.features = ExtractFreeRocking(record, options.features);
  CheckRocks(record, out.features, out, options);
  return out;
}

}  // namespace fit_detail

// --- public ------------------------------------------------------------------

const char* ToString(QuarterTime q) { return q == QuarterTime::kExact ? "exact" : "slender"; }
const char* ToString(FitMethod m) { return m == FitMethod::kImpacts ? "impacts" : "trajectory"; }

QuarterTime ParseQuarterTime(const std::string& name) {
  if (name == "exact") return QuarterTime::kExact;
  if (name == "slender") return QuarterTime::kSlender;
  throw std::invalid_argument("quarter time must be exact or slender, got '" + name + "'");
}

FitMethod ParseFitMethod(const std::string& name) {
  if (name == "impacts") return FitMethod::kImpacts;
  if (name == "trajectory") return FitMethod::kTrajectory;
  throw std::invalid_argument("method must be impacts or trajectory, got '" + name + "'");
}

double QuarterTimeOf(QuarterTime kind, double alpha, double p, double r) {
  return kind == QuarterTime::kExact ? QuarterTimeExact(alpha, p, r) : QuarterTimeSlender(alpha, p, r);
}

AlphaBand AdmissibleAlphaBand(const FitGeometry& g, double band_m) {
  if (!(band_m >= 0.0) || !std::isfinite(band_m)) {
    throw std::invalid_argument("alpha band must be >= 0 m, got " + Num(band_m));
  }
  if (!(g.width_m - 2.0 * band_m - 2.0 * g.chamfer_m > 0.0)) {
    throw std::invalid_argument("alpha band " + Num(band_m) + " m leaves no half-width of the base (width " +
                                Num(g.width_m) + " m, chamfer " + Num(g.chamfer_m) + " m)");
  }
  AlphaBand b;
  b.band_m = band_m;
  b.geometric = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).alpha;
  b.lo = RectangleBlock(g.width_m - 2.0 * band_m, g.height_m, g.chamfer_m).alpha;
  b.hi = RectangleBlock(g.width_m + 2.0 * band_m, g.height_m, g.chamfer_m).alpha;
  return b;
}

void FitOptions::Validate() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(alpha_band_m >= 0.0)) bad("alpha band must be >= 0 m, got " + Num(alpha_band_m));
  if (min_impacts < 3) bad("min impacts must be >= 3, got " + std::to_string(min_impacts));
  if (!(rtol > 0.0 && rtol < 1e-3)) bad("rtol must be in (0, 1e-3), got " + Num(rtol));
  if (max_evaluations < 10) bad("max evaluations must be >= 10");
  if (!(features.hysteresis_rad >= 0.0)) bad("hysteresis must be >= 0 rad");
  if (!(features.crossing_window_s > 0.0)) bad("crossing window must be > 0 s");
  if (!(features.min_peak_rad >= 0.0)) bad("min peak must be >= 0 rad");
  if (!(features.min_hold_s >= 0.0)) bad("min hold must be >= 0 s");
  if (!(features.overturn_rad > 0.0)) bad("overturn angle must be > 0 rad");
  if (start) start->Validate();
}


}  // namespace rocklab::model
