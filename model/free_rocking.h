#pragma once
/// @file
/// Closed-form and quadrature results of free rocking (no table motion),
/// corrected as in docs/errata.md items 2 and 7. Oracles for the models and the
/// basis of the paper's parameter identification.

#include <cstddef>
#include <vector>

#include "model/block.h"
#include "model/rocking_model.h"

namespace rocklab::model {

/// Time from a peak |theta| = r to the next impact (corrected eq. 12), s:
/// T(r) = 1/(p sqrt 2) * integral_0^r dx / sqrt(cos(alpha - r) - cos(alpha - x)),
/// integrated through its inverse-square-root singularity at x = r by a
/// substitution; relative accuracy about 1e-12.
/// @throws std::invalid_argument unless 0 < r < alpha < pi/2 and p > 0.
double QuarterTimeExact(double alpha, double p, double r);

/// Slender-block limit (eq. 13), s: T(r) = acosh(1 / (1 - r/alpha)) / p.
/// @throws std::invalid_argument unless 0 < r < alpha and p > 0.
double QuarterTimeSlender(double alpha, double p, double r);

/// Peak |theta| after an impact that multiplies theta_dot by mu, from the
/// peak r before it (energy conservation between impacts), rad.
double NextPeak(double alpha, double mu, double r);

/// Eq. (14) (docs/errata.md item 7): mu_n = [(cos(alpha - r_n) - cos alpha) /
/// (cos(alpha - r_0) - cos alpha)]^(1/(2n)), r_n the peak after impact n.
/// @throws std::invalid_argument unless n >= 1 and 0 < r_n, r_0 < alpha.
double MuFromPeaks(double alpha, double r0, double rn, int n);

/// What SampleFreeHousner met on the way.
struct FreeHousnerRun {
  bool overturned{false};  ///< |theta| reached pi/2: the samples from there on are NaN
  bool rested{false};      ///< two impacts closer than the rest interval: theta = 0 after
  int impacts{};
};

/// Housner's model (the equations of RockingModel's Housner, model/housner.cpp)
/// in free rocking, no table motion, sampled at the times t[0 .. n): from
/// theta0, theta_dot0 at t0_s (both 0: at rest for ever) to theta[k] at t[k]
/// (non-decreasing, >= t0_s). Classical Runge-Kutta (RK4) with steps that
/// end on every sample time and are at most kFreeHousnerMaxPh / p long; an
/// impact (theta crossing 0, shifted by 1e-14 rad as the model's root) is
/// placed by Newton's method on the RK4 step itself, theta_dot is multiplied
/// by mu of the pivot it lands on, and two impacts closer than
/// rest_impact_interval_s put the block at rest (RockingModel's rule, with
/// no table to lift it again). Block 1 at 1 kHz: impact times within 8e-11 s
/// of the closed-form chain (QuarterTimeExact, NextPeak), theta within 1e-8
/// rad of the CVODE model at rtol 1e-10 (tests/model/free_rocking_test.cpp;
/// the speed, docs/performance.md "Posterior").
/// `impact_times_s`, when given, receives the impact times.
/// @throws std::invalid_argument for invalid parameters, |theta0| >= pi/2,
///         non-finite values or times out of order.
FreeHousnerRun SampleFreeHousner(const BlockParams& params, double t0_s, double theta0, double theta_dot0,
                                 const double* t_s, std::size_t n, double* theta,
                                 double rest_impact_interval_s = ModelOptions{}.rest_impact_interval_s,
                                 std::vector<double>* impact_times_s = nullptr);

/// p h of SampleFreeHousner's longest step: RK4's global error is about
/// (p h)^4 / 120 of the motion's scale per unit p t (5e-3: ~5e-12 per
/// radian and p t).
inline constexpr double kFreeHousnerMaxPh = 5e-3;

}  // namespace rocklab::model
