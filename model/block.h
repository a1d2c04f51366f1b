#pragma once
/// @file
/// Block parameters (alpha, p, mu) from the geometry of a section.
///
/// A section rocks about the extreme corners of its base: the +x pivot for
/// theta > 0 and the -x pivot for theta < 0. A symmetric section has the same
/// parameters on both sides; an asymmetric one has its own alpha, R and p on
/// each side, and the restitution of an impact depends on the pair of pivots
/// (see PolygonBlock).

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/units.h"

namespace rocklab::model {

/// Gravity used throughout, m/s^2 (the value with which the paper's Table 1
/// is reproduced; docs/errata.md item 1), written once in common/units.h.
using common::kGravity;

/// The parameters of one side (one pivot) of a section.
struct SideParams {
  double alpha{};  ///< angle of the centroid seen from this pivot, from vertical, rad; in (0, pi/2)
  double p{};      ///< sqrt(M g R / I_O) about this pivot, rad/s; > 0
  /// Restitution of the angular velocity at an impact that lands on this
  /// pivot (coming from the other one), 1; in (0, 1].
  double mu{};
};

/// The three parameters of planar rocking. alpha, p and mu are those of the
/// +x side (theta > 0); `minus`, when present, those of the -x side
/// (theta < 0). Without it the block is symmetric: every BlockParams{alpha, p,
/// mu} means the same parameters on both sides.
struct BlockParams {
  double alpha{};  ///< angle of the centroid seen from the pivot, from vertical, rad; in (0, pi/2)
  double p{};      ///< frequency parameter sqrt(M g R / I_O), rad/s; > 0
  double mu{};     ///< coefficient of restitution of the angular velocity (impact onto this side), 1; in (0, 1]
  std::optional<SideParams> minus{};  ///< the theta < 0 side of an asymmetric section

  bool symmetric() const { return !minus.has_value(); }
  /// The parameters of the side a block rocks on: +1 (theta > 0) or -1.
  SideParams Side(int side) const { return side >= 0 || !minus ? SideParams{alpha, p, mu} : *minus; }

  /// @throws std::invalid_argument naming the parameter (alpha, p or mu, and
  ///         minus.alpha etc.) when it is out of range or not finite.
  void Validate() const;
};

/// One side of a section: its pivot and what follows from it.
struct SideGeometry {
  double R{};             ///< pivot to centroid distance, m
  double alpha{};         ///< angle of the centroid seen from the pivot, from vertical, rad
  double p{};             ///< sqrt(M g R / I_O), rad/s
  double i_o_per_area{};  ///< polar moment of area about the pivot / area, m^2 (I_O / M)
  /// Restitution of an impact landing on this pivot from the other one, 1:
  /// (I_G + M r_new . r_old) / I_O,new (see PolygonBlock).
  double mu{};
  Eigen::Vector2d pivot_m{Eigen::Vector2d::Zero()};  ///< pivot in the polygon's frame, m
};

/// Properties of a planar section. The unprefixed fields are those of the
/// +x side (rocking about the +x base corner, theta > 0); `minus` is the -x
/// side.
struct BlockGeometry {
  double R{};             ///< pivot to centroid distance, m
  double alpha{};         ///< angle of the centroid seen from the pivot, from vertical, rad
  double p{};             ///< sqrt(M g R / I_O), rad/s
  double area{};          ///< section area, m^2
  double i_o_per_area{};  ///< polar moment of area about the pivot / area, m^2 (I_O / M)
  double mu_housner{};    ///< 1 - 1.5 sin^2(alpha), eq. (11), 1
  /// Restitution of an impact onto the +x pivot, 1: 1 - (2 M R^2 / I_O)
  /// sin^2(alpha) for a symmetric section (docs/errata.md item 8).
  double mu_general{};
  double i_g_per_area{};  ///< polar moment of area about the centroid / area, m^2 (I_G / M)
  Eigen::Vector2d centroid_m{Eigen::Vector2d::Zero()};  ///< in the polygon's frame, m
  SideGeometry plus;      ///< the +x side (the same values as the unprefixed fields)
  SideGeometry minus;     ///< the -x side
  /// Both sides have the same alpha, p and mu to 1e-9 (relative).
  bool symmetric{true};

  /// alpha, p and the general-section mu of the +x side, and the -x side's
  /// when the section is not symmetric.
  BlockParams params() const;
};

/// A rectangle of width 2b and height 2h, optionally with a 45 degree chamfer
/// of leg `chamfer_m` on both base corners; the pivot is then the inner end of
/// the cut (docs/errata.md item 9).
/// @param width_m 2b, m; > 0
/// @param height_m 2h, m; > 0
/// @param chamfer_m leg of the base chamfer, m; in [0, min(b, h))
/// @param g gravity, m/s^2
/// @throws std::invalid_argument naming the argument when out of range.
BlockGeometry RectangleBlock(double width_m, double height_m, double chamfer_m = 0.0,
                             double g = kGravity);

/// A simple polygon section standing on its base, vertices in order (either
/// orientation; a last vertex equal to the first is dropped), m, in any frame
/// with z (the second coordinate) up. The pivots are the lowest vertices with
/// the largest x (+x side) and the smallest x (-x side). Per side, alpha and R
/// come from the centroid seen from the pivot, p = sqrt(g R / (I_O / M)) from
/// the polar moment about the pivot. The restitution of an impact from the
/// old pivot to the new one conserves the angular momentum about the new
/// pivot: I_G w + M r_new x (w x r_old) = I_O,new w', r = centroid - pivot, so
/// mu = w'/w = (I_G + M r_new . r_old) / I_O,new; for a symmetric section
/// r_new . r_old = R^2 cos(2 alpha) and mu = 1 - (2 M R^2 / I_O) sin^2 alpha
/// (docs/errata.md item 8).
/// @throws std::invalid_argument for fewer than 3 vertices, a vertex not
///         finite, a repeated vertex, crossing edges, zero area, a base that is
///         one vertex, or a centroid not above the base between the pivots.
BlockGeometry PolygonBlock(const std::vector<Eigen::Vector2d>& vertices_m, double g = kGravity);

/// A pair of edges (i, j), i < j, edge k running from vertex k to vertex
/// k + 1 (mod n), that are not neighbours and touch or cross, or two
/// neighbours that overlap (the outline turning back: a spike); nullopt for
/// a simple polygon. O(n log n) time (a sweep, model/block.cpp).
/// @param pair_tests when not null, set to the number of edge pairs tested
///        (at most 3n).
std::optional<std::pair<std::size_t, std::size_t>> FindCrossingEdges(
    const std::vector<Eigen::Vector2d>& vertices_m, std::size_t* pair_tests = nullptr);

/// A polygon read from a CSV file: header `x,z` (m), one vertex a line, in
/// order; blank lines and lines starting with '#' skipped.
struct PolygonFile {
  std::string path;
  std::vector<Eigen::Vector2d> vertices_m;  ///< m
  std::vector<int> line;                    ///< line of each vertex in the file
};

/// Reads and checks a polygon CSV (numbers, at least 3 vertices, no repeated
/// vertex, no crossing edges).
/// @throws std::invalid_argument "PATH:LINE: ..." (or "PATH: ..." for the
///         whole file) on the first problem.
PolygonFile ReadPolygonCsv(const std::string& path);

/// PolygonBlock of a file read by ReadPolygonCsv.
/// @throws std::invalid_argument "PATH: ..." as ReadPolygonCsv and PolygonBlock.
BlockGeometry PolygonBlock(const PolygonFile& polygon, double g = kGravity);

}  // namespace rocklab::model
