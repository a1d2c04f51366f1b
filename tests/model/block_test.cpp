// Tests of model/block.h. Oracle: the paper's Table 1 (as corrected by
// ERRATA items 1 and 9) and closed forms for a rectangle.
#include "model/block.h"

#include <gtest/gtest.h>

#include <cmath>
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

struct Row {
  double width_m, height_m, alpha, p, mu;
};

// ORACLE: Table 1 rows 1-3, p as ERRATA item 1 prints it (3.780, 3.809,
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

// ORACLE: ERRATA item 9 (alpha 0.310 printed in Table 1; p = 5.21 from the
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
}

}  // namespace
}  // namespace rocklab::model
