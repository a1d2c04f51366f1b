#pragma once
/// @file
/// Closed-form and quadrature results of free rocking (no table motion),
/// corrected as in docs/errata.md items 2 and 7. Oracles for the models and the
/// basis of the paper's parameter identification.

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

}  // namespace rocklab::model
