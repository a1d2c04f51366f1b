#pragma once
/// @file
/// An assembly of rigid bodies against its measurement: one Comparator per
/// body (the single block's figures), and the contact mode read from the
/// measured angles against the model's (docs/compare.md, "Comparing an
/// assembly"). No allocation after construction.

#include <cstdint>
#include <string>
#include <vector>

#include "compare/comparator.h"

namespace rocklab::compare {

/// The assembly's contact mode read from per-body angles (bottom-up, rad,
/// the single block's sign: > 0 rocking on the +x corner): per interface k
/// (under body k; 0: the table) the relative angle r_k = theta_k -
/// theta_{k-1} (theta_{-1} = 0) names it 'R' (r_k > rest_rad), 'L' (r_k <
/// -rest_rad) or 'C' (closed). Into `out` (resized to n; no allocation once
/// it has grown). A non-finite angle gives '?'.
void MeasuredMode(const double* theta, int n, double rest_rad, std::string& out);

/// The fraction of samples where the model's mode equals the measured one.
struct ModeAgreement {
  std::string model;        ///< the model's mode at the latest pair ("" unknown)
  std::string measured;     ///< the measured mode at the latest pair
  double rest_rad{};        ///< MeasuredMode's threshold, rad
  std::int64_t samples{};   ///< pairs that entered the fraction
  std::int64_t agreeing{};  ///< of them, the modes equal
  /// agreeing / samples, 1; NaN before any sample (nothing to say).
  double fraction() const;
};

/// Knobs of a BodiesComparator.
struct BodiesComparatorOptions {
  ComparatorOptions comparator;  ///< per body
  /// MeasuredMode's threshold, rad; >= 0. 2e-3 rad: the comparator's
  /// crossing hysteresis (an angle below it is not told from rest there
  /// either), above the reconstruction's noise (docs/compare.md).
  double mode_rest_rad{2e-3};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// Running comparison of one assembly variant (n bodies) with the
/// measurement of the same bodies.
class BodiesComparator {
 public:
  /// @throws std::invalid_argument for invalid options or n < 1.
  BodiesComparator(int nbodies, const BodiesComparatorOptions& options = {});

  /// One aligned sample (utime strictly increasing): per body the measured
  /// and modelled angle (rad) and whether the body's measurement is valid
  /// (its DAQ flags: no sliding, jump or twist), and the model's mode. The
  /// mode enters the agreement when every body is valid and `model_mode`
  /// names n interfaces; otherwise only `model` and `measured` change.
  void Add(std::int64_t utime, const double* measured, const bool* valid, const double* model,
           const std::string& model_mode);

  int nbodies() const { return static_cast<int>(bodies_.size()); }
  const ComparisonMetrics& body(int k) const { return bodies_[static_cast<std::size_t>(k)].metrics(); }
  const ModeAgreement& mode() const { return mode_; }

 private:
  std::vector<Comparator> bodies_;
  ModeAgreement mode_;
};

}  // namespace rocklab::compare
