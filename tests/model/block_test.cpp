// Tests of model/block.h. Oracle: the paper's Table 1 (as corrected by
// docs/errata.md items 1 and 9) and closed forms for a rectangle.
#include "model/block.h"
#include "tests/scratch.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>
#include <stdexcept>
#include <string>

namespace rocklab::model {
namespace {

std::string ErrorOf(void (*f)()) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

template <typename F>
std::string ErrorOf2(const F& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

struct Row {
  double width_m, height_m, alpha, p, mu;
};

// ORACLE: Table 1 rows 1-3, p as docs/errata.md item 1 prints it (3.780, 3.809,
// 3.822: the paper prints 3.810 and 3.820, which a rectangle with g = 9.81
// does not give). TOLERANCE: half a unit of the last printed digit (5e-4).
TEST(BlockTest, TableOneRowsOneToThreeToPrintedDigits) {
  const Row rows[] = {{0.247, 1.000, 0.242, 3.780, 0.914},
                      {0.168, 1.000, 0.166, 3.809, 0.959},
                      {0.120, 1.000, 0.119, 3.822, 0.979}};
  for (const Row& r : rows) {
    const BlockGeometry g = RectangleBlock(r.width_m, r.height_m);
    EXPECT_NEAR(g.alpha, r.alpha, 5e-4) << r.width_m;
    EXPECT_NEAR(g.p, r.p, 5e-4) << r.width_m;
    EXPECT_NEAR(g.mu_housner, r.mu, 5e-4) << r.width_m;
    // ORACLE: closed forms R = sqrt(b^2 + h^2), p = sqrt(3 g / (4 R)).
    const double R = std::hypot(r.width_m / 2, r.height_m / 2);
    EXPECT_NEAR(g.R, R, 1e-14);
    EXPECT_NEAR(g.p, std::sqrt(3 * kGravity / (4 * R)), 1e-12);
    EXPECT_NEAR(g.i_o_per_area, 4.0 / 3.0 * R * R, 1e-14);
  }
}

// ORACLE: docs/errata.md item 9 (alpha 0.310 printed in Table 1; p = 5.21 from the
// polygon with a 4.2 cm chamfer). TOLERANCE: alpha 0.005 (the chamfer is
// "about" 4.2 cm, the brief's bound); p 0.01 (two printed digits).
TEST(BlockTest, TableOneRowFourWithChamfer) {
  const BlockGeometry g = RectangleBlock(0.246, 0.500, 0.042);
  EXPECT_NEAR(g.alpha, 0.310, 0.005);
  EXPECT_NEAR(g.p, 5.21, 0.01);
  // The pivot moves inwards by the cut: alpha is below the plain rectangle's.
  EXPECT_LT(g.alpha, std::atan(0.123 / 0.25));
}

// ORACLE: a plain rectangle as a polygon must give the closed-form rectangle
// (both orientations, any start vertex); mu_general == mu_housner since
// I_O = 4/3 M R^2. TOLERANCE: rounding of the shoelace sums, 1e-13.
TEST(BlockTest, PolygonOfRectangleEqualsRectangle) {
  const BlockGeometry r = RectangleBlock(0.3, 0.8);
  const std::vector<Eigen::Vector2d> ccw = {{-0.15, 0.0}, {0.15, 0.0}, {0.15, 0.8}, {-0.15, 0.8}};
  const std::vector<Eigen::Vector2d> cw = {{0.15, 0.8}, {0.15, 0.0}, {-0.15, 0.0}, {-0.15, 0.8}};
  for (const auto& v : {ccw, cw}) {
    const BlockGeometry g = PolygonBlock(v);
    EXPECT_NEAR(g.alpha, r.alpha, 1e-13);
    EXPECT_NEAR(g.p, r.p, 1e-13);
    EXPECT_NEAR(g.R, r.R, 1e-13);
    EXPECT_NEAR(g.area, 0.24, 1e-13);
    EXPECT_NEAR(g.mu_general, g.mu_housner, 1e-13);
  }
  EXPECT_NEAR(r.mu_general, r.mu_housner, 1e-13);
  EXPECT_EQ(r.params().mu, r.mu_general);
}

// ORACLE: a right trapezoid computed by hand, split into the rectangle
// [0, 0.2] x [0, 1] (area 0.2) and the triangle (0.2, 0), (0.4, 0), (0.2, 1)
// (area 0.1): area 0.3, centroid (7/45, 4/9), polar moment about the origin
// 0.0693333 + 0.024 = 0.0933333 m^4, so I_G / M = 14/45 - 449/2025 =
// 181/2025 m^2. Pivots (0.4, 0) (+x) and (0, 0) (-x):
// r_+ = (-11/45, 20/45), r_- = (7/45, 20/45); alpha_+ = atan(11/20),
// alpha_- = atan(7/20); I_+/M = 702/2025, I_-/M = 630/2025; r_+ . r_- =
// 323/2025, so an impact onto + keeps (181 + 323)/702 = 504/702 of the
// angular velocity and one onto - keeps 504/630 = 0.8.
// TOLERANCE: rounding of the shoelace sums, 1e-13.
TEST(BlockTest, RightTrapezoidPerSideByHand) {
  const BlockGeometry g = PolygonBlock({{0.0, 0.0}, {0.4, 0.0}, {0.2, 1.0}, {0.0, 1.0}});
  EXPECT_NEAR(g.area, 0.3, 1e-13);
  EXPECT_NEAR(g.centroid_m.x(), 7.0 / 45, 1e-13);
  EXPECT_NEAR(g.centroid_m.y(), 4.0 / 9, 1e-13);
  EXPECT_NEAR(g.i_g_per_area, 181.0 / 2025, 1e-13);
  EXPECT_FALSE(g.symmetric);
  EXPECT_NEAR(g.plus.alpha, std::atan(11.0 / 20), 1e-13);
  EXPECT_NEAR(g.minus.alpha, std::atan(7.0 / 20), 1e-13);
  EXPECT_NEAR(g.plus.R, std::sqrt(521.0) / 45, 1e-13);
  EXPECT_NEAR(g.minus.R, std::sqrt(449.0) / 45, 1e-13);
  EXPECT_NEAR(g.plus.i_o_per_area, 702.0 / 2025, 1e-13);
  EXPECT_NEAR(g.minus.i_o_per_area, 630.0 / 2025, 1e-13);
  EXPECT_NEAR(g.plus.p, std::sqrt(kGravity * (std::sqrt(521.0) / 45) / (702.0 / 2025)), 1e-12);
  EXPECT_NEAR(g.minus.p, std::sqrt(kGravity * (std::sqrt(449.0) / 45) / (630.0 / 2025)), 1e-12);
  EXPECT_NEAR(g.plus.mu, 504.0 / 702, 1e-13);
  EXPECT_NEAR(g.minus.mu, 0.8, 1e-13);
  // The unprefixed fields are the +x side; params() carries both.
  EXPECT_EQ(g.alpha, g.plus.alpha);
  EXPECT_EQ(g.mu_general, g.plus.mu);
  const BlockParams bp = g.params();
  ASSERT_TRUE(bp.minus.has_value());
  EXPECT_EQ(bp.Side(+1).alpha, g.plus.alpha);
  EXPECT_EQ(bp.Side(-1).alpha, g.minus.alpha);
  EXPECT_EQ(bp.Side(-1).mu, g.minus.mu);
  EXPECT_NO_THROW(bp.Validate());
  // Mirrored (x -> -x) the sides swap.
  const BlockGeometry m = PolygonBlock({{0.0, 0.0}, {0.0, 1.0}, {-0.2, 1.0}, {-0.4, 0.0}});
  EXPECT_NEAR(m.plus.alpha, g.minus.alpha, 1e-13);
  EXPECT_NEAR(m.minus.mu, g.plus.mu, 1e-13);
}

// ORACLE: docs/errata.md item 8. For a symmetric section (block 4's chamfered
// rectangle and a symmetric pentagon, "house" shape) r_new . r_old =
// R^2 cos(2 alpha), so the pair-of-pivots restitution must reduce to
// 1 - (2 M R^2 / I_O) sin^2(alpha) on both sides, and params() must be the
// symmetric BlockParams{alpha, p, mu} (no minus side).
// TOLERANCE: rounding, 1e-13.
TEST(BlockTest, SymmetricSectionReducesToErrataItem8) {
  const BlockGeometry chamfered = RectangleBlock(0.246, 0.500, 0.042);
  const BlockGeometry house = PolygonBlock({{-0.2, 0.0}, {0.2, 0.0}, {0.2, 0.8}, {0.0, 1.1}, {-0.2, 0.8}});
  for (const BlockGeometry& g : {chamfered, house}) {
    const double s = std::sin(g.alpha);
    const double item8 = 1.0 - 2.0 * g.R * g.R / g.i_o_per_area * s * s;
    EXPECT_NEAR(g.plus.mu, item8, 1e-13);
    EXPECT_NEAR(g.minus.mu, item8, 1e-13);
    EXPECT_NEAR(g.minus.alpha, g.plus.alpha, 1e-13);
    EXPECT_NEAR(g.minus.p, g.plus.p, 1e-13);
    EXPECT_TRUE(g.symmetric);
    EXPECT_FALSE(g.params().minus.has_value());
  }
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = test::ScratchDir("block_test");
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string CsvError(const std::string& name, const std::string& text) {
  try {
    (void)PolygonBlock(ReadPolygonCsv(WriteFile(name, text)));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// ORACLE: the values written (a closed outline's repeated first vertex is
// dropped), and the contract: every error names the file and, where there
// is one, the line.
TEST(BlockTest, PolygonCsvReadsAndNamesFileAndLine) {
  const std::string path = WriteFile("trapezoid.csv", "# right trapezoid\nx,z\n0,0\n0.4,0\n\n0.2,1\n0,1\n0,0\n");
  const PolygonFile f = ReadPolygonCsv(path);
  ASSERT_EQ(f.vertices_m.size(), 4u);
  EXPECT_EQ(f.line[2], 6);
  EXPECT_NEAR(PolygonBlock(f).minus.mu, 0.8, 1e-13);

  EXPECT_NE(CsvError("h.csv", "x,y\n0,0\n").find("h.csv:1: the header must be x,z"), std::string::npos);
  EXPECT_NE(CsvError("n.csv", "x,z\n0,0\n1,zero\n1,1\n").find("n.csv:3: expected two finite numbers"),
            std::string::npos);
  EXPECT_NE(CsvError("f.csv", "x,z\n0,0\n1,0,2\n1,1\n").find("f.csv:3:"), std::string::npos);
  EXPECT_NE(CsvError("few.csv", "x,z\n0,0\n1,0\n").find("few.csv: a polygon needs at least 3"),
            std::string::npos);
  EXPECT_NE(CsvError("rep.csv", "x,z\n0,0\n1,0\n1,0\n1,1\n").find("rep.csv:4: repeats the vertex of line 3"),
            std::string::npos);
  // A bow tie: the edge from line 2 to 3 crosses the edge from line 4 to 5.
  EXPECT_NE(CsvError("tie.csv", "x,z\n0,0\n1,1\n1,0\n0,1\n").find("tie.csv:2: the edge from line 2 to line 3"),
            std::string::npos);
  EXPECT_NE(CsvError("tip.csv", "x,z\n0,0\n1,1\n-1,1\n").find("tip.csv: the section rests on one vertex"),
            std::string::npos);
  // An L lying on its short foot: the centroid is beyond the +x pivot.
  EXPECT_NE(CsvError("l.csv", "x,z\n0,0\n0.1,0\n0.1,0.1\n1,0.1\n1,0.2\n0,0.2\n")
                .find("l.csv: centroid x"),
            std::string::npos);
  EXPECT_NE(CsvError("none.csv", "").find("none.csv: empty file"), std::string::npos);
  try {
    ReadPolygonCsv("/nonexistent/p.csv");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/p.csv: cannot open"), std::string::npos);
  }
}

// ORACLE: the contract — errors name the argument or parameter.
TEST(BlockTest, BadArgumentsNameThemselves) {
  EXPECT_NE(ErrorOf([] { RectangleBlock(-1, 1); }).find("width_m"), std::string::npos);
  EXPECT_NE(ErrorOf([] { RectangleBlock(1, 0); }).find("height_m"), std::string::npos);
  EXPECT_NE(ErrorOf([] { RectangleBlock(0.2, 1, 0.1); }).find("chamfer_m"), std::string::npos);
  EXPECT_NE(ErrorOf([] { PolygonBlock({{0, 0}, {1, 0}}); }).find("3 vertices"), std::string::npos);
  EXPECT_NE(ErrorOf([] { PolygonBlock({{0, 0}, {1, 0}, {2, 0}}); }).find("zero area"), std::string::npos);
  EXPECT_NE(ErrorOf([] { BlockParams{0.0, 3, 0.9}.Validate(); }).find("alpha"), std::string::npos);
  EXPECT_NE(ErrorOf([] { BlockParams{0.2, -3, 0.9}.Validate(); }).find("p "), std::string::npos);
  EXPECT_NE(ErrorOf([] { BlockParams{0.2, 3, 1.5}.Validate(); }).find("mu"), std::string::npos);
  EXPECT_NE(ErrorOf([] { BlockParams{0.2, 3, NAN}.Validate(); }).find("mu"), std::string::npos);
  EXPECT_NO_THROW((BlockParams{0.235, 3.884, 0.937}.Validate()));
  BlockParams asym{0.235, 3.884, 0.937};
  asym.minus = SideParams{0.3, 3.9, 1.2};
  EXPECT_NE(ErrorOf2([&] { asym.Validate(); }).find("minus.mu"), std::string::npos);
}

// A 1 x 1 square whose right side carries k trapezoidal teeth out to x = 2
// (4 vertices a tooth): 4k + 3 vertices, and about k edges under the sweep
// line at once. Tooth t spans z in [t h, (t + 0.75) h], h = 1 / k.
std::vector<Eigen::Vector2d> Comb(std::size_t k) {
  const double h = 1.0 / static_cast<double>(k);
  std::vector<Eigen::Vector2d> v{{0.0, 0.0}};
  for (std::size_t t = 0; t < k; ++t) {
    const double z = static_cast<double>(t) * h;
    v.insert(v.end(), {{1.0, z}, {2.0, z + 0.25 * h}, {2.0, z + 0.5 * h}, {1.0, z + 0.75 * h}});
  }
  v.insert(v.end(), {{1.0, 1.0}, {0.0, 1.0}});
  return v;
}

// ORACLE: closed form: the square (area 1, centroid x 0.5) and k trapezoids
// of parallel sides 0.75 h and 0.25 h, width 1 (area 0.5 h each, centroid
// 1 + (0.75 + 2 * 0.25) / (3 * (0.75 + 0.25)) = 1 + 1.25 / 3 in x). The
// sweep tests at most 3 pairs an edge (one per end of an edge entering,
// one as it leaves): a million vertices in about 3 million tests where
// testing every pair took 5e11 (over 120 s for block_params).
TEST(BlockTest, AMillionVertexSectionIsCheckedInLinearlyManyEdgeTests) {
  const std::vector<Eigen::Vector2d> v = Comb(250000);
  ASSERT_EQ(v.size(), 1000003u);
  std::size_t tests = 0;
  EXPECT_FALSE(FindCrossingEdges(v, &tests).has_value());
  EXPECT_LE(tests, 3 * v.size());
  const BlockGeometry g = PolygonBlock(v);
  EXPECT_NEAR(g.area, 1.5, 1e-9);  // rounding of a million shoelace terms of size ~1e-6
  EXPECT_NEAR(g.centroid_m.x(), (0.5 + 0.5 * (1.0 + 1.25 / 3.0)) / 1.5, 1e-9);

  // One tooth bent up across the next one: edges 4t+2 (from its moved
  // vertex 4t+3) and 4t+3 cross the next tooth's first edge 4t+5.
  std::vector<Eigen::Vector2d> bent = v;
  const std::size_t t = 123456, moved = 4 * t + 3;
  bent[moved] = {1.9, (static_cast<double>(t) + 1.4) / 250000.0};
  tests = 0;
  const auto crossing = FindCrossingEdges(bent, &tests);
  ASSERT_TRUE(crossing.has_value());
  EXPECT_TRUE(crossing->first == moved - 1 || crossing->first == moved) << crossing->first;
  EXPECT_EQ(crossing->second, moved + 2);
  EXPECT_LE(tests, 3 * v.size());
}

// Two closed segments share a point: exact integer arithmetic, written
// here apart from model/block.cpp.
bool Meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d) {
  const auto orient = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
    const double x = (q - p).x() * (r - p).y() - (q - p).y() * (r - p).x();
    return (x > 0) - (x < 0);
  };
  const auto within = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) && std::min(p.y(), q.y()) <= r.y() &&
           r.y() <= std::max(p.y(), q.y());
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && within(a, b, c)) || (o2 == 0 && within(a, b, d)) || (o3 == 0 && within(c, d, a)) ||
         (o4 == 0 && within(c, d, b));
}

// ORACLE: every pair of edges tested (O(n^2), written above) on 100 000
// seeded polygons of 4 to 9 vertices on a 7 x 7 integer grid, where
// touching, collinear and shared-vertex cases are common: the sweep finds
// a touching pair exactly when one exists, and the pair it names touches.
// A spike (an outline turning back along its last edge) counts as two
// neighbouring edges that touch; testing every pair of non-neighbours
// accepted one on its own.
TEST(BlockTest, SweepFindsACrossingExactlyWhenEveryPairTestFindsOne) {
  std::mt19937 rng(34);
  std::uniform_int_distribution<int> coord(0, 6), count(4, 9);
  int crossing = 0, simple = 0;
  for (int trial = 0; trial < 100000; ++trial) {
    std::vector<Eigen::Vector2d> v(static_cast<std::size_t>(count(rng)));
    for (auto& p : v) p = Eigen::Vector2d(coord(rng), coord(rng));
    const std::size_t n = v.size();
    bool degenerate = false;
    for (std::size_t i = 0; i < n; ++i) degenerate = degenerate || v[i] == v[(i + 1) % n];
    if (degenerate) continue;  // a zero-length edge: refused before the check
    bool expected = false;
    for (std::size_t k = 0; k < n && !expected; ++k) {  // a spike: neighbours that overlap
      const Eigen::Vector2d back = v[(k + n - 1) % n] - v[k], ahead = v[(k + 1) % n] - v[k];
      expected = back.x() * ahead.y() == back.y() * ahead.x() && back.dot(ahead) > 0;
    }
    for (std::size_t i = 0; i < n && !expected; ++i) {
      for (std::size_t j = i + 2; j < n && !expected; ++j) {
        if (i == 0 && j == n - 1) continue;
        expected = Meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]);
      }
    }
    const auto found = FindCrossingEdges(v);
    ASSERT_EQ(found.has_value(), expected) << "trial " << trial << ": " << [&v] {
      std::string text;
      for (const auto& p : v) text += "(" + std::to_string(int(p.x())) + "," + std::to_string(int(p.y())) + ") ";
      return text;
    }();
    if (found) {
      const auto [i, j] = *found;
      EXPECT_TRUE(Meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n])) << "trial " << trial;  // also a spike's pair
      ++crossing;
    } else {
      ++simple;
    }
  }
  EXPECT_GT(simple, 5000);  // both outcomes are exercised
  EXPECT_GT(crossing, 5000);
}

}  // namespace
}  // namespace rocklab::model
