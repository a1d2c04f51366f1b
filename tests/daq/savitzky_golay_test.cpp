// Savitzky-Golay differentiator. Oracles: (1) a least-squares polynomial of
// degree `order` reproduces any polynomial of that degree, so its value and
// derivatives are exact up to rounding, at the centre and at the segment
// edges alike; (2) on white noise of standard deviation sigma, the output's
// standard deviation is sigma * ||w|| (w the centre weights); (3) every input
// gets exactly one output, in order, delayed by m samples (by `lag` samples
// for the filter evaluated off-centre); (4) for order 2 the off-centre
// weights and their noise gain have a closed form (below).
#include <algorithm>
#include <cmath>
#include <cstdint>
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

// The RMS of the first and second derivative estimates of `sg` fed `count`
// samples of Gaussian white noise of standard deviation `sigma` (seed
// `seed`), over the outputs from `skip` after the first to `skip` before the
// last (the segment's edge windows left out).
struct NoiseRms {
  double d1{}, d2{};
};
NoiseRms MeasureNoiseRms(SavitzkyGolay& sg, double sigma, std::size_t count, std::uint64_t seed,
                         std::size_t skip) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  std::vector<double> x(count);
  for (auto& v : x) v = normal(rng);
  const auto out = Filter(sg, x);
  double ss1 = 0, ss2 = 0;
  int n = 0;
  for (size_t k = skip; k + skip < out.size(); ++k, ++n) {
    ss1 += out[k].d1 * out[k].d1;
    ss2 += out[k].d2 * out[k].d2;
  }
  return {std::sqrt(ss1 / n), std::sqrt(ss2 / n)};
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
  const NoiseRms rms = MeasureNoiseRms(sg, sigma, 40000, 42, 25);
  const double want1 = sigma * sg.CentreWeights(1).norm();
  const double want2 = sigma * sg.CentreWeights(2).norm();
  // The outputs are correlated over a window (51 samples): about 40000/51 ~
  // 800 independent values, so the sample standard deviation is within
  // 1/sqrt(2*800) ~ 2.5 % (1 sigma); 10 % is 4 sigma.
  EXPECT_NEAR(rms.d1 / want1, 1.0, 0.10);
  EXPECT_NEAR(rms.d2 / want2, 1.0, 0.10);
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

// Oracle (1) off-centre: the least-squares polynomial evaluated `lag`
// samples behind the newest reproduces a polynomial of its degree exactly,
// in the stream, at a segment's start (cut windows) and at its end (Finish).
// Tolerance: rounding of sum w_i y_i, at most n eps sum |w_i| |y_i| for the
// dot product; with the weights' own rounding (Gram-Schmidt on a scaled
// basis, ~1e-13 relative) and the cut windows' larger weights, 1e-9 of
// ||w||_1 max|y| bounds it with margin (measured: below 1e-13 of it).
TEST(SavitzkyGolay, OffCentreReproducesPolynomialsOfItsOrder) {
  const double dt = 1e-3;
  const double a[] = {1e-3, 2e-3, -3e-3, 0.5e-3, -4e-3, 1e-3, -2e-3};
  for (int order : {2, 3, 4, 6}) {
    auto u = [&](double t, int deriv) {  // derivative `deriv` of sum a_c t^c
      double sum = 0;
      for (int c = deriv; c <= order; ++c) {
        double f = 1;
        for (int j = 0; j < deriv; ++j) f *= c - j;
        sum += a[c] * f * std::pow(t, c - deriv);
      }
      return sum;
    };
    for (int m : {3, 25}) {
      if (order >= 2 * m + 1) continue;
      for (int lag : {0, 1, m / 2, m - 1, m}) {
        SavitzkyGolay sg(m, order, dt, lag);
        ASSERT_EQ(sg.delay_samples(), lag);
        std::vector<double> x;
        double ymax = 0;
        for (int k = 0; k < 200; ++k) {
          x.push_back(u(k * dt, 0));
          ymax = std::max(ymax, std::abs(x.back()));
        }
        const double tol1 = 1e-9 * sg.LagWeights(1).lpNorm<1>() * ymax;
        const double tol2 = 1e-9 * sg.LagWeights(2).lpNorm<1>() * ymax;
        const auto out = Filter(sg, x);
        ASSERT_EQ(out.size(), x.size());
        for (size_t k = 0; k < out.size(); ++k) {
          const double t = k * dt;
          ASSERT_EQ(out[k].index, static_cast<int64_t>(k));
          // A window of fewer than order+1 samples (the segment's first
          // order - lag outputs) fits a lower degree: not exact.
          if (static_cast<int>(k) + lag < order) continue;
          EXPECT_NEAR(out[k].value, u(t, 0), 1e-12) << order << " " << m << " " << lag << " " << k;
          EXPECT_NEAR(out[k].d1, u(t, 1), tol1) << order << " " << m << " " << lag << " " << k;
          EXPECT_NEAR(out[k].d2, u(t, 2), tol2) << order << " " << m << " " << lag << " " << k;
        }
      }
    }
  }
}

// Oracle (3) off-centre: sample k leaves when sample k + lag arrives.
TEST(SavitzkyGolay, OutputsStreamLagSamplesLate) {
  for (int lag : {0, 1, 2, 3}) {
    SavitzkyGolay sg(3, 2, 1.0, lag);
    SgOutput o;
    for (int k = 0; k < 12; ++k) {
      sg.Push(2.0 * k);
      if (k < lag) {
        EXPECT_FALSE(sg.Pop(o)) << lag << " " << k;
        continue;
      }
      ASSERT_TRUE(sg.Pop(o)) << lag << " " << k;
      EXPECT_EQ(o.index, k - lag);
      if (k >= 1) {
        EXPECT_NEAR(o.d1, 2.0, 1e-12);
      }
      EXPECT_FALSE(sg.Pop(o));
    }
    sg.Finish();
    int n = 0;
    while (sg.Pop(o)) ++n;
    EXPECT_EQ(n, lag);
  }
  EXPECT_THROW(SavitzkyGolay(3, 2, 1.0, -1), std::invalid_argument);
  EXPECT_THROW(SavitzkyGolay(3, 2, 1.0, 4), std::invalid_argument);
}

// Oracle (4): order 2 on i = -m..m. The basis 1, i, i^2 - S2/n is orthogonal
// on the symmetric window (S2 = sum i^2 = m (m+1) (2m+1) / 3, n = 2m+1), so
// the fit's coefficients are b1 = sum i y / S2 and b2 = sum (i^2 - S2/n) y / S4
// (S4 = sum (i^2 - S2/n)^2), and the slope at s = m - lag samples towards the
// newest is (b1 + 2 b2 s) / dt: weight_i = (i / S2 + 2 s (i^2 - S2/n) / S4) / dt,
// noise gain^2 = (1 / S2 + 4 s^2 / S4) / dt^2, larger than the centred
// 1 / (S2 dt^2) whenever s != 0. The second derivative 2 b2 / dt^2 does not
// depend on s. Tolerance: 1e-12 relative (rounding of the numerical weights).
TEST(SavitzkyGolay, OffCentreWeightsAndNoiseGainOfOrderTwoHaveAClosedForm) {
  const double dt = 1e-3;
  for (int m : {2, 5, 50}) {
    const double n = 2 * m + 1;
    const double s2 = m * (m + 1.0) * (2 * m + 1.0) / 3;
    double s4 = 0;
    for (int i = -m; i <= m; ++i) s4 += std::pow(i * i - s2 / n, 2);
    for (int lag = 0; lag <= m; ++lag) {
      const SavitzkyGolay sg(m, 2, dt, lag);
      const double s = m - lag;
      const Eigen::VectorXd w1 = sg.LagWeights(1);
      const Eigen::VectorXd w2 = sg.LagWeights(2);
      ASSERT_EQ(w1.size(), 2 * m + 1);
      double sum_sq = 0;
      for (int i = -m; i <= m; ++i) {
        const double want1 = (i / s2 + 2 * s * (i * i - s2 / n) / s4) / dt;
        const double want2 = 2 * (i * i - s2 / n) / s4 / (dt * dt);
        EXPECT_NEAR(w1(i + m), want1, 1e-12 * std::abs(w1.maxCoeff())) << m << " " << lag << " " << i;
        EXPECT_NEAR(w2(i + m), want2, 1e-12 * std::abs(w2.maxCoeff())) << m << " " << lag << " " << i;
        sum_sq += w1(i + m) * w1(i + m);
      }
      const double gain = std::sqrt(1 / s2 + 4 * s * s / s4) / dt;
      EXPECT_NEAR(sg.NoiseGain(1), gain, 1e-12 * gain);
      EXPECT_NEAR(sg.NoiseGain(1), std::sqrt(sum_sq), 1e-12 * gain);  // the sum of squared weights
      const double centred = 1 / std::sqrt(s2) / dt;
      if (lag < m) {
        EXPECT_GT(sg.NoiseGain(1), centred * (1 + 1e-9)) << m << " " << lag;
      }
      EXPECT_NEAR(sg.NoiseGain(2), 2 / std::sqrt(s4) / (dt * dt), 1e-12 * sg.NoiseGain(2));
    }
  }
}

// The table's filter (order 4, m = 50 at 1 kHz) evaluated at theta_dot's
// delay (5 samples): its noise gain, measured on white noise, is the one
// NoiseGain states (oracle (2) off-centre). The velocity's gain is larger
// off-centre at every lag (the order-2 closed form above proves it for
// order 2; checked here for order 4); the acceleration's is larger at the
// lags docs/acquisition.md tabulates (0, 5, 20) but not everywhere: a
// quartic's second derivative is better determined somewhat off-centre
// (0.67 of the centred gain at lag 33).
TEST(SavitzkyGolay, OffCentreNoiseGainIsMeasuredAndLargerThanCentred) {
  const double dt = 1e-3, sigma = 2e-5;
  const SavitzkyGolay centred(50, 4, dt);
  for (int lag = 0; lag < 50; ++lag) {
    EXPECT_GT(SavitzkyGolay(50, 4, dt, lag).NoiseGain(1), centred.NoiseGain(1)) << lag;
  }
  for (int lag : {0, 5, 20}) {
    EXPECT_GT(SavitzkyGolay(50, 4, dt, lag).NoiseGain(2), centred.NoiseGain(2)) << lag;
  }
  EXPECT_LT(SavitzkyGolay(50, 4, dt, 33).NoiseGain(2), 0.7 * centred.NoiseGain(2));
  EXPECT_EQ(centred.NoiseGain(1), std::sqrt(centred.CentreWeights(1).squaredNorm()));
  SavitzkyGolay sg(50, 4, dt, 5);
  const NoiseRms rms = MeasureNoiseRms(sg, sigma, 60000, 43, 100);
  // About 60000 / 101 ~ 590 independent windows: the sample standard
  // deviation is within 1/sqrt(2*590) ~ 3 % (1 sigma); 12 % is 4 sigma.
  EXPECT_NEAR(rms.d1 / (sigma * sg.NoiseGain(1)), 1.0, 0.12);
  EXPECT_NEAR(rms.d2 / (sigma * sg.NoiseGain(2)), 1.0, 0.12);
}

}  // namespace
}  // namespace rocklab::daq
