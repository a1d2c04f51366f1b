// The models on an asymmetric section: each half-cycle uses the parameters
// of the pivot the block rocks on, the uplift criterion is g tan(alpha) of
// the side it lifts onto, and an impact's restitution is that of the pair of
// pivots (model/block.h). A symmetric section must give exactly the
// rectangle's results.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "model/block.h"
#include "model/excitation.h"
#include "model/free_rocking.h"
#include "model/rocking_model.h"

namespace rocklab::model {
namespace {

// The right trapezoid of block_test (pivots (0.4, 0) and (0, 0), height 1 m).
BlockGeometry Trapezoid() { return PolygonBlock({{0.0, 0.0}, {0.4, 0.0}, {0.2, 1.0}, {0.0, 1.0}}); }

struct Cycle {
  double impact_time_s;
  double peak_after_rad;  // |theta| peak after this impact
};

// Oracle: free rocking per side from energy conservation between impacts
// and the corrected eq. (12) (ERRATA item 2) evaluated with that side's
// alpha and p. From a release at r_0 on side s: the impact comes T_s(r_0)
// later with theta_dot^2 = 2 p_s^2 (cos(alpha_s - r_0) - cos alpha_s); the
// block lands on the other pivot o with theta_dot' = mu_o theta_dot, rises
// to r_1 where cos(alpha_o - r_1) - cos alpha_o = theta_dot'^2 / (2 p_o^2),
// and comes back 2 T_o(r_1) later. Half-cycles alternate sides.
std::vector<Cycle> FreeRockingOracle(const BlockParams& bp, double t0, double theta0, int n) {
  std::vector<Cycle> out;
  int side = theta0 > 0 ? +1 : -1;
  SideParams sp = bp.Side(side);
  double r = std::abs(theta0);
  double t = t0 + QuarterTimeExact(sp.alpha, sp.p, r);
  for (int i = 0; i < n; ++i) {
    const double w2 = 2 * sp.p * sp.p * (std::cos(sp.alpha - r) - std::cos(sp.alpha));
    side = -side;
    sp = bp.Side(side);
    const double w_after = sp.mu * std::sqrt(w2);
    r = sp.alpha - std::acos(std::cos(sp.alpha) + w_after * w_after / (2 * sp.p * sp.p));
    out.push_back({t, r});
    t += 2 * QuarterTimeExact(sp.alpha, sp.p, r);
  }
  return out;
}

// Housner and the complex formulation (which integrates an asymmetric block
// in its l -> 0 limit, Housner's equations in (chi, psi)) against the
// per-side oracle. Tolerance: impact times 1e-9 s and peaks 1e-7 rad
// (measured 2e-11 s and 8e-9 rad, the latter the sampled maximum's bias of
// up to theta'' dt^2 / 8 at dt = 1e-4 s; CVODE at rtol 1e-10 and the
// quadrature of eq. (12) allow no more). A mix-up of the sides misses by
// over 1e-3 s (checked below).
TEST(AsymmetricModel, FreeRockingAlternatesSidesAsTheOracle) {
  const BlockParams bp = Trapezoid().params();
  ASSERT_TRUE(bp.minus.has_value());
  const NoTableMotion zero;
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    for (double sign : {+1.0, -1.0}) {
      // A quarter of alpha: from half of alpha_+ the block would overturn on
      // its less stable -x side.
      const double theta0 = sign * 0.25 * bp.Side(static_cast<int>(sign)).alpha;
      auto m = RockingModel::Create(kind, bp);
      m->Reset(0.0, theta0, 0.0);
      std::vector<double> peaks;
      double peak = 0.0;
      double t = 0.0;
      // Sample |theta| finely to find each half-cycle's peak.
      std::size_t impacts_seen = 0;
      while (t < 6.0 && m->state().regime == Regime::kRocking) {
        t += 1e-4;
        m->AdvanceTo(t, zero);
        std::size_t impacts = 0;
        for (const auto& e : m->events()) impacts += e.kind == EventKind::kImpact ? 1 : 0;
        if (impacts > impacts_seen) {
          if (impacts_seen > 0) peaks.push_back(peak);
          impacts_seen = impacts;
          peak = 0.0;
        }
        peak = std::max(peak, std::abs(m->state().theta));
      }
      const auto oracle = FreeRockingOracle(bp, 0.0, theta0, 6);
      std::vector<double> times;
      for (const auto& e : m->events()) {
        if (e.kind == EventKind::kImpact) times.push_back(e.time_s);
      }
      ASSERT_GE(times.size(), 6u) << ToString(kind);
      ASSERT_GE(peaks.size(), 5u) << ToString(kind);
      double worst_t = 0.0;
      double worst_r = 0.0;
      for (std::size_t i = 0; i < 6; ++i) {
        EXPECT_NEAR(times[i], oracle[i].impact_time_s, 1e-9) << ToString(kind) << " impact " << i + 1;
        worst_t = std::max(worst_t, std::abs(times[i] - oracle[i].impact_time_s));
        if (i < 5) worst_r = std::max(worst_r, std::abs(peaks[i] - oracle[i].peak_after_rad));
      }
      std::printf("%s from %+.4f rad: worst impact time %.2e s, peak %.2e rad\n", ToString(kind), theta0, worst_t,
                  worst_r);
      for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_NEAR(peaks[i], oracle[i].peak_after_rad, 1e-7) << ToString(kind) << " peak " << i + 1;
      }
      // The sides really differ: a symmetric oracle would miss the first
      // impact after a -x half-cycle by far more than the tolerance.
      const BlockParams sym{bp.alpha, bp.p, bp.mu};
      EXPECT_GT(std::abs(FreeRockingOracle(sym, 0.0, theta0, 3)[2].impact_time_s - oracle[2].impact_time_s), 1e-3);
    }
  }
}

// Oracle: the uplift criterion of the side the block lifts onto. A table
// acceleration ramp a t from rest lifts the block when a t = g tan(alpha_-)
// (u_g'' > 0 tips it onto -x, ERRATA items 5-6) or, for -a t, when
// a t = g tan(alpha_+). Tolerance 1e-9 s (CVODE root finding on a linear
// forcing).
TEST(AsymmetricModel, UpliftUsesTheSideItLiftsOnto) {
  const BlockParams bp = Trapezoid().params();
  const double a = 20.0;  // m/s^3
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    for (double sign : {+1.0, -1.0}) {
      const SampledAcceleration ramp({0.0, 1.0}, {0.0, sign * a});
      auto m = RockingModel::Create(kind, bp);
      m->Reset(0.0, 0.0, 0.0);
      m->AdvanceTo(0.6, ramp);
      ASSERT_FALSE(m->events().empty());
      const ModelEvent& e = m->events().front();
      ASSERT_EQ(e.kind, EventKind::kUplift);
      const int side = sign > 0 ? -1 : +1;
      EXPECT_NEAR(e.time_s, kGravity * std::tan(bp.Side(side).alpha) / a, 1e-9) << ToString(kind);
      EXPECT_EQ(m->state().theta > 0 ? +1 : -1, side) << ToString(kind);
    }
  }
}

// Oracle: a symmetric polygon is the rectangle, exactly. The same vertices
// as RectangleBlock gives bit-identical parameters (no minus side), so both
// models give bit-identical trajectories; and a BlockParams whose minus side
// repeats the plus side goes through the per-side code and must still give
// Housner's symmetric trajectory bit for bit.
TEST(AsymmetricModel, SymmetricPolygonGivesExactlyTheRectangle) {
  const BlockParams rect = RectangleBlock(0.247, 1.0).params();
  const BlockParams poly = PolygonBlock({{-0.1235, 0.0}, {0.1235, 0.0}, {0.1235, 1.0}, {-0.1235, 1.0}}).params();
  ASSERT_FALSE(poly.minus.has_value());
  EXPECT_EQ(rect.alpha, poly.alpha);
  EXPECT_EQ(rect.p, poly.p);
  EXPECT_EQ(rect.mu, poly.mu);
  BlockParams twin = rect;
  twin.minus = SideParams{rect.alpha, rect.p, rect.mu};
  const auto ex = ParseExcitation("hanning:amp=0.010,freq=3.3,duration=4,start=0.5");
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    auto a = RockingModel::Create(kind, rect);
    auto b = RockingModel::Create(kind, poly);
    const Trajectory ta = Simulate(*a, *ex, 0.0, 0.0, 0.0, 6.0, 200);
    const Trajectory tb = Simulate(*b, *ex, 0.0, 0.0, 0.0, 6.0, 200);
    ASSERT_EQ(ta.theta.size(), tb.theta.size());
    for (std::size_t k = 0; k < ta.theta.size(); ++k) ASSERT_EQ(ta.theta[k], tb.theta[k]) << ToString(kind) << " " << k;
    EXPECT_GT(ta.events.size(), 3u);
  }
  auto h = RockingModel::Create(ModelKind::kHousner, rect);
  auto t = RockingModel::Create(ModelKind::kHousner, twin);
  const Trajectory th = Simulate(*h, *ex, 0.0, 0.0, 0.0, 6.0, 200);
  const Trajectory tt = Simulate(*t, *ex, 0.0, 0.0, 0.0, 6.0, 200);
  for (std::size_t k = 0; k < th.theta.size(); ++k) ASSERT_EQ(th.theta[k], tt.theta[k]) << k;
}

}  // namespace
}  // namespace rocklab::model
