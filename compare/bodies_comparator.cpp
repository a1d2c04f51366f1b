#include "compare/bodies_comparator.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace rocklab::compare {

void MeasuredMode(const double* theta, int n, double rest_rad, std::string& out) {
  out.resize(static_cast<std::size_t>(n > 0 ? n : 0));
  double below = 0.0;  // the table
  for (int k = 0; k < n; ++k) {
    const double relative = theta[k] - below;
    char c = 'C';
    if (!std::isfinite(relative)) {
      c = '?';
    } else if (relative > rest_rad) {
      c = 'R';
    } else if (relative < -rest_rad) {
      c = 'L';
    }
    out[static_cast<std::size_t>(k)] = c;
    below = theta[k];
  }
}

double ModeAgreement::fraction() const {
  return samples > 0 ? static_cast<double>(agreeing) / static_cast<double>(samples)
                     : std::numeric_limits<double>::quiet_NaN();
}

void BodiesComparatorOptions::Validate() const {
  comparator.Validate();
  if (!(std::isfinite(mode_rest_rad) && mode_rest_rad >= 0)) {
    throw std::invalid_argument("comparator option mode_rest_rad out of range");
  }
}

BodiesComparator::BodiesComparator(int nbodies, const BodiesComparatorOptions& options) {
  options.Validate();
  if (nbodies < 1) throw std::invalid_argument("comparator: an assembly has at least one body");
  bodies_.reserve(static_cast<std::size_t>(nbodies));
  for (int k = 0; k < nbodies; ++k) bodies_.emplace_back(options.comparator);
  mode_.rest_rad = options.mode_rest_rad;
  mode_.model.reserve(static_cast<std::size_t>(nbodies));
  mode_.measured.reserve(static_cast<std::size_t>(nbodies));
}

void BodiesComparator::Add(std::int64_t utime, const double* measured, const bool* valid,
                           const double* model, const std::string& model_mode) {
  const int n = nbodies();
  bool all_valid = true;
  for (int k = 0; k < n; ++k) {
    const ComparisonMetrics& m = bodies_[static_cast<std::size_t>(k)].Add(utime, measured[k], model[k], valid[k]);
    all_valid = all_valid && m.valid;
  }
  mode_.model = model_mode;
  MeasuredMode(measured, n, mode_.rest_rad, mode_.measured);
  if (all_valid && model_mode.size() == static_cast<std::size_t>(n)) {
    ++mode_.samples;
    if (model_mode == mode_.measured) ++mode_.agreeing;
  }
}

}  // namespace rocklab::compare
