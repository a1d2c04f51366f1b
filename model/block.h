#pragma once
/// @file
/// Block parameters (alpha, p, mu) from the geometry of a section.

#include <vector>

#include <Eigen/Core>

#include "common/units.h"

namespace rocklab::model {

/// Gravity used throughout, m/s^2 (the value with which the paper's Table 1
/// is reproduced; ERRATA item 1), written once in common/units.h.
using common::kGravity;

/// The three parameters of planar rocking.
struct BlockParams {
  double alpha{};  ///< angle of the centroid seen from the pivot, from vertical, rad; in (0, pi/2)
  double p{};      ///< frequency parameter sqrt(M g R / I_O), rad/s; > 0
  double mu{};     ///< coefficient of restitution of the angular velocity, 1; in (0, 1]

  /// @throws std::invalid_argument naming the parameter (alpha, p or mu) when
  ///         it is out of range or not finite.
  void Validate() const;
};

/// Properties of a planar section rocking about its +x base corner.
struct BlockGeometry {
  double R{};             ///< pivot to centroid distance, m
  double alpha{};         ///< angle of the centroid seen from the pivot, from vertical, rad
  double p{};             ///< sqrt(M g R / I_O), rad/s
  double area{};          ///< section area, m^2
  double i_o_per_area{};  ///< polar moment of area about the pivot / area, m^2 (I_O / M)
  double mu_housner{};    ///< 1 - 1.5 sin^2(alpha), eq. (11), 1
  double mu_general{};    ///< 1 - (2 M R^2 / I_O) sin^2(alpha), ERRATA item 8, 1

  /// alpha, p and the general-section mu (equal to mu_housner for a rectangle).
  BlockParams params() const { return {alpha, p, mu_general}; }
};

/// A rectangle of width 2b and height 2h, optionally with a 45 degree chamfer
/// of leg `chamfer_m` on both base corners; the pivot is then the inner end of
/// the cut (ERRATA item 9).
/// @param width_m 2b, m; > 0
/// @param height_m 2h, m; > 0
/// @param chamfer_m leg of the base chamfer, m; in [0, min(b, h))
/// @param g gravity, m/s^2
/// @throws std::invalid_argument naming the argument when out of range.
BlockGeometry RectangleBlock(double width_m, double height_m, double chamfer_m = 0.0,
                             double g = kGravity);

/// A simple polygon section standing on its lowest edge, vertices in order
/// (either orientation), m. The pivot is the lowest vertex with the largest x.
/// alpha, R and I_O come from the polygon's area, centroid and polar moment
/// about the pivot. The section is assumed symmetric enough that rocking about
/// the -x corner has the same parameters.
/// @throws std::invalid_argument for fewer than 3 vertices, zero area, or a
///         centroid not above the base.
BlockGeometry PolygonBlock(const std::vector<Eigen::Vector2d>& vertices_m, double g = kGravity);

}  // namespace rocklab::model
