// Savitzky-Golay differentiator. Oracles: (1) a least-squares polynomial of
// degree `order` reproduces any polynomial of that degree, so its value and
// derivatives are exact up to rounding, at the centre and at the segment
// edges alike; (2) on white noise of standard deviation sigma, the output's
// standard deviation is sigma * ||w|| (w the centre weights); (3) every input
// gets exactly one output, in order, delayed by m samples.
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "daq/savitzky_golay.h"

namespace rocklab::daq {
namespace {

std::vector<SgOutput> Filter(SavitzkyGolay& sg, const std::vector<double>& x) {
  std::vector<SgOutput> out;
  SgOutput o;
  for (double v : x) {
    sg.Push(v);
    while (sg.Pop(o)) out.push_back(o);
  }
  sg.Finish();
  while (sg.Pop(o)) out.push_back(o);
  return out;
}

TEST(SavitzkyGolay, ReproducesPolynomialsOfItsOrderEverywhere) {
  const double dt = 1e-3;
  // Quartic in t: value 1e-3 scale like a table displacement in m.
  auto u = [](double t) { return 1e-3 * (1 + 2 * t - 3 * t * t + 0.5 * t * t * t - 4 * t * t * t * t); };
  auto du = [](double t) { return 1e-3 * (2 - 6 * t + 1.5 * t * t - 16 * t * t * t); };
  auto ddu = [](double t) { return 1e-3 * (-6 + 3 * t - 48 * t * t); };
  SavitzkyGolay sg(25, 4, dt);
  std::vector<double> x;
  for (int k = 0; k < 300; ++k) x.push_back(u(k * dt));
  const auto out = Filter(sg, x);
  ASSERT_EQ(out.size(), x.size());
  for (size_t k = 0; k < out.size(); ++k) {
    const double t = k * dt;
    EXPECT_EQ(out[k].index, static_cast<int64_t>(k));
    // Rounding: the weights sum |w| ~ 1/dt^d times O(1e2); inputs ~1e-3.
    EXPECT_NEAR(out[k].value, u(t), 1e-14);
    EXPECT_NEAR(out[k].d1, du(t), 1e-10);
    EXPECT_NEAR(out[k].d2, ddu(t), 1e-7);
  }
}

TEST(SavitzkyGolay, ShortSegmentUsesALowerOrderFit) {
  SavitzkyGolay sg(5, 2, 0.01);
  // Three samples of a line: the fit (order 2) is exact; d2 = 0.
  const auto out = Filter(sg, {1.0, 1.5, 2.0});
  ASSERT_EQ(out.size(), 3u);
  for (const auto& o : out) {
    EXPECT_NEAR(o.d1, 50.0, 1e-9);
    EXPECT_NEAR(o.d2, 0.0, 1e-6);
  }
  // One sample: no derivative can be formed.
  SavitzkyGolay one(5, 2, 0.01);
  const auto single = Filter(one, {3.0});
  ASSERT_EQ(single.size(), 1u);
  EXPECT_EQ(single[0].value, 3.0);
  EXPECT_TRUE(std::isnan(single[0].d1));
}

TEST(SavitzkyGolay, OutputsStreamOnePerInputHalfAWindowLate) {
  SavitzkyGolay sg(3, 2, 1.0);
  SgOutput o;
  for (int k = 0; k < 3; ++k) {
    sg.Push(k);
    EXPECT_FALSE(sg.Pop(o)) << k;  // sample k - m does not exist yet
  }
  for (int k = 3; k < 10; ++k) {
    sg.Push(k);
    ASSERT_TRUE(sg.Pop(o));
    EXPECT_EQ(o.index, k - 3);  // sample k releases sample k - m, and only it
    EXPECT_NEAR(o.d1, 1.0, 1e-12);
    EXPECT_FALSE(sg.Pop(o));
  }
  sg.Finish();  // the last m outputs
  int n = 0;
  while (sg.Pop(o)) ++n;
  EXPECT_EQ(n, 3);
}

TEST(SavitzkyGolay, NoiseGainIsTheNormOfTheWeights) {
  const double dt = 1e-3, sigma = 2e-5;
  SavitzkyGolay sg(25, 4, dt);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal(0.0, sigma);
  std::vector<double> x(40000);
  for (auto& v : x) v = normal(rng);
  const auto out = Filter(sg, x);
  double ss1 = 0, ss2 = 0;
  int n = 0;
  for (size_t k = 25; k + 25 < out.size(); ++k, ++n) {
    ss1 += out[k].d1 * out[k].d1;
    ss2 += out[k].d2 * out[k].d2;
  }
  const double want1 = sigma * sg.CentreWeights(1).norm();
  const double want2 = sigma * sg.CentreWeights(2).norm();
  // The outputs are correlated over a window (51 samples): about 40000/51 ~
  // 800 independent values, so the sample standard deviation is within
  // 1/sqrt(2*800) ~ 2.5 % (1 sigma); 10 % is 4 sigma.
  EXPECT_NEAR(std::sqrt(ss1 / n) / want1, 1.0, 0.10);
  EXPECT_NEAR(std::sqrt(ss2 / n) / want2, 1.0, 0.10);
}

// Several inputs pushed between pops (the processor bridges a short gap that
// way), also in a segment's first window: every output still comes from
// samples of the segment. Oracle: a straight line is reproduced exactly by
// every fit of degree >= 1, whatever window an output uses.
TEST(SavitzkyGolay, OutputsThatLagStayExact) {
  for (int m : {1, 3, 5, 25}) {
    SavitzkyGolay sg(m, 2, 1e-3);
    int64_t k = 0;
    SgOutput o;
    int checked = 0;
    for (int step = 0; step < 200; ++step) {
      const int burst = step % 7 == 3 ? m : 1;  // m inputs at once now and then
      for (int b = 0; b < burst; ++b, ++k) sg.Push(1.0 + 2.0 * static_cast<double>(k) * 1e-3);
      while (sg.Pop(o)) {
        ASSERT_FALSE(std::isnan(o.d1));
        EXPECT_NEAR(o.value, 1.0 + 2.0 * static_cast<double>(o.index) * 1e-3, 1e-12) << m << " " << o.index;
        EXPECT_NEAR(o.d1, 2.0, 1e-8) << m << " " << o.index;
        ++checked;
      }
      if (step % 50 == 49) sg.Finish();
    }
    EXPECT_GT(checked, 150);
  }
}

// The largest window the rig allows (m = 1000) is set up in O(n) and is as
// exact as a small one. Oracle: a quartic is reproduced.
TEST(SavitzkyGolay, LargestWindowIsExact) {
  const int m = 1000;
  const double dt = 1e-3;
  SavitzkyGolay sg(m, 4, dt);
  auto u = [](double t) { return 1e-3 * (1 + 2 * t - 3 * t * t + 0.5 * t * t * t - 0.4 * t * t * t * t); };
  auto du = [](double t) { return 1e-3 * (2 - 6 * t + 1.5 * t * t - 1.6 * t * t * t); };
  std::vector<double> x;
  for (int k = 0; k < 2 * m + 500; ++k) x.push_back(u(k * dt));
  const auto out = Filter(sg, x);
  ASSERT_EQ(out.size(), x.size());
  for (size_t k = 0; k < out.size(); k += 37) {
    EXPECT_NEAR(out[k].value, u(k * dt), 1e-12) << k;
    EXPECT_NEAR(out[k].d1, du(k * dt), 1e-9) << k;
  }
  EXPECT_THROW(SavitzkyGolay(SavitzkyGolay::kMaxHalfWindow + 1, 2, dt), std::invalid_argument);
  EXPECT_THROW(SavitzkyGolay(5, 7, dt), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::daq
