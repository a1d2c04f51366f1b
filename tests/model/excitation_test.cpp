// Tests of model/excitation.h. Oracles: closed forms, finite differences of
// the displacement, and the documented error messages.
#include "model/excitation.h"
#include "tests/scratch.h"
#include "common/units.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace rocklab::model {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares

std::string ParseError(const std::string& spec) {
  try {
    ParseExcitation(spec);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// ORACLE: u'' = -U w^2 sin(w (t - start)) inside, 0 outside. TOLERANCE: 1e-12
// (a handful of roundings of O(1) numbers).
TEST(ExcitationTest, SineClosedForm) {
  const auto s = MakeSine({0.006, 5.0, 20.0, 1.0});
  const double w = 2 * kPi * 5.0;
  EXPECT_EQ(s->TableAcceleration(0.5), 0.0);
  EXPECT_EQ(s->Displacement(21.5), 0.0);
  for (double t : {1.0, 1.03, 7.77, 21.0}) {
    EXPECT_NEAR(s->Displacement(t), 0.006 * std::sin(w * (t - 1)), 1e-12);
    EXPECT_NEAR(s->Velocity(t), 0.006 * w * std::cos(w * (t - 1)), 1e-12);
    EXPECT_NEAR(s->TableAcceleration(t), -0.006 * w * w * std::sin(w * (t - 1)), 1e-12);
  }
}

// ORACLE: docs/errata.md item 11 — the acceleration is the exact second derivative of
// U A(t - tc) sin(2 pi f (t - start)): compared with central differences of
// Displacement and Velocity, Richardson-extrapolated (4 D(h/2) - D(h)) / 3.
// TOLERANCE: truncation ~h^4/480 max|u^(6)| with h = 1e-3 and
// |u^(6)| <~ U (2 pi f)^6 (1.3)^6 ~ 4e5 (window terms add the 1.3): ~1e-9;
// rounding ~1e-16 * 0.13 / h ~ 1e-14: 1e-8.
TEST(ExcitationTest, HanningDerivativesAreExact) {
  const auto e = MakeHanningSine({0.006, 3.3, 4.0, 0.5});
  auto d = [](auto f, double t) {
    const double h = 1e-3;
    const double d1 = (f(t + h) - f(t - h)) / (2 * h);
    const double d2 = (f(t + h / 2) - f(t - h / 2)) / h;
    return (4 * d2 - d1) / 3;
  };
  auto u = [&e](double t) { return e->Displacement(t); };
  auto v = [&e](double t) { return e->Velocity(t); };
  for (double t = 0.6; t < 4.45; t += 0.0371) {
    EXPECT_NEAR(e->Velocity(t), d(u, t), 1e-8) << t;
    EXPECT_NEAR(e->TableAcceleration(t), d(v, t), 1e-8) << t;
  }
  // The window: zero at the ends, full amplitude at the centre t_c = 2.5 s.
  EXPECT_NEAR(e->Displacement(0.5), 0.0, 1e-15);
  EXPECT_NEAR(e->Displacement(4.5), 0.0, 1e-15);
  EXPECT_EQ(e->Displacement(4.6), 0.0);
  const double tc = 2.5;
  EXPECT_NEAR(e->Displacement(tc), 0.006 * std::sin(2 * kPi * 3.3 * 2.0), 1e-15);
  // Not U (2 pi f)^2 times the window (the misreading docs/errata.md item 11 warns of).
  const double naive = -0.006 * std::pow(2 * kPi * 3.3, 2) * 0.5 * (1 + std::cos(kPi * 0.3 / 2)) *
                       std::sin(2 * kPi * 3.3 * 2.3);
  EXPECT_GT(std::abs(e->TableAcceleration(2.8) - naive), 1e-3);
}

// ORACLE: linearity of the sum.
TEST(ExcitationTest, SumAddsParts) {
  std::vector<std::unique_ptr<Excitation>> parts;
  parts.push_back(MakeSine({0.002, 2.0, 5.0, 0.0}));
  parts.push_back(MakeHanningSine({0.004, 3.0, 4.0, 1.0}));
  const auto a = MakeSine({0.002, 2.0, 5.0, 0.0});
  const auto b = MakeHanningSine({0.004, 3.0, 4.0, 1.0});
  const auto sum = MakeSum(std::move(parts));
  for (double t : {0.3, 1.7, 2.9}) {
    EXPECT_DOUBLE_EQ(sum->TableAcceleration(t), a->TableAcceleration(t) + b->TableAcceleration(t));
    EXPECT_DOUBLE_EQ(sum->Velocity(t), a->Velocity(t) + b->Velocity(t));
  }
}

// ORACLE: the documented spec syntax and messages.
TEST(ExcitationTest, ParseGoodAndBad) {
  const auto e = ParseExcitation("hanning:amp=0.006,freq=3.3,duration=4,start=0.5");
  const auto ref = MakeHanningSine({0.006, 3.3, 4.0, 0.5});
  EXPECT_EQ(e->TableAcceleration(2.1), ref->TableAcceleration(2.1));
  const auto s = ParseExcitation("sine:amp=0.006,freq=5,duration=20");  // start defaults to 0
  EXPECT_EQ(s->TableAcceleration(0.01), MakeSine({0.006, 5, 20, 0})->TableAcceleration(0.01));

  EXPECT_EQ(ParseError("sine:ampl=1"),
            "unknown excitation key 'ampl' in 'sine:ampl=1' (expected amp, freq, duration, start)");
  EXPECT_NE(ParseError("square:amp=1,freq=1,duration=1").find("kind 'square'"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=abc,freq=1,duration=1").find("key 'amp'"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=1,freq=1").find("missing key 'duration'"), std::string::npos);
  EXPECT_NE(ParseError("sine:freq=1,duration=1").find("missing key 'amp'"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=1,duration=1").find("missing key 'freq'"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=1,freq=-2,duration=1").find("freq"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=1,freq=2,duration=1,start=-1").find("start"), std::string::npos);
  EXPECT_NE(ParseError("sine:amp=nan,freq=2,duration=1").find("amp"), std::string::npos);
  EXPECT_NE(ParseError("sine").find("KIND"), std::string::npos);
  // Issue 34: 1e308 m made the acceleration inf and the block "never
  // uplifts". Oracle: U (2 pi f + pi/a)^2, a = duration/2, against 1e6 m/s^2:
  // 1e308 m overflows; 900 m at 5 Hz (20 s) is 9.06e5 m/s^2 (taken) and
  // 2 km 2.01e6 m/s^2 (refused).
  EXPECT_NE(ParseError("sine:amp=1e308,freq=5,duration=20").find("beyond the 1000000 m/s^2"), std::string::npos)
      << ParseError("sine:amp=1e308,freq=5,duration=20");
  EXPECT_NE(ParseError("hanning:amp=2000,freq=5,duration=20").find("excitation amp 2000 m at freq 5 Hz"),
            std::string::npos);
  EXPECT_NO_THROW(ParseExcitation("sine:amp=900,freq=5,duration=20"));
}

// ORACLE: linear interpolation by hand; zero outside.
TEST(ExcitationTest, SampledAccelerationIsLinearAndZeroOutside) {
  SampledAcceleration s({0.0, 1.0, 3.0}, {0.0, 2.0, -2.0});
  EXPECT_EQ(s.TableAcceleration(-0.1), 0.0);
  EXPECT_EQ(s.TableAcceleration(3.1), 0.0);
  EXPECT_DOUBLE_EQ(s.TableAcceleration(0.5), 1.0);
  EXPECT_DOUBLE_EQ(s.TableAcceleration(1.0), 2.0);
  EXPECT_DOUBLE_EQ(s.TableAcceleration(2.0), 0.0);
  EXPECT_DOUBLE_EQ(s.TableAcceleration(3.0), -2.0);
  EXPECT_THROW(SampledAcceleration({0.0, 1.0}, {0.0}), std::invalid_argument);
  EXPECT_THROW(SampledAcceleration({0.0}, {0.0}), std::invalid_argument);
  try {
    SampledAcceleration({0.0, 1.0, 1.0}, {0.0, 1.0, 2.0});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("time_s[2]"), std::string::npos);
  }
  try {
    SampledAcceleration({0.0, 1.0}, {0.0, INFINITY});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("accel_mps2[1]"), std::string::npos);
  }
}

// ORACLE: polynomials the interpolants reproduce exactly. The not-a-knot
// spline is exact for every cubic on any spacing (its third derivative is
// continuous at the second and last but one samples, so with 4 samples it
// is the one cubic through them); Catmull-Rom's centred slopes are exact
// for a quadratic on equal spacing (inside: the end intervals take a
// one-sided slope). Tolerance 1e-12 relative to the values (~1e1): the
// tridiagonal solve's rounding. 2 samples: the spline is the chord; 3: the
// natural spline, M = 0 at the ends and M1 = 6 ((a2 - a1) / h1 - (a1 - a0)
// / h0) / (2 (h0 + h1)) (by hand: 0, 1, 0 at t = 0, 1, 3 gives M1 = -1.5,
// a(0.5) = 0.5 + 0.25 / 6 (1.5) (1.5) = 0.59375).
TEST(ExcitationTest, SplineAndCatmullRomReproduceTheirPolynomials) {
  auto cubic = [](double t) { return 1.5 - 2.0 * t + 0.7 * t * t - 0.3 * t * t * t; };
  auto quadratic = [](double t) { return 0.4 + 1.1 * t - 0.9 * t * t; };
  for (const std::vector<double>& t :
       {std::vector<double>{0.0, 0.3, 1.0, 1.2}, std::vector<double>{-1.0, -0.2, 0.1, 0.9, 1.0, 2.5, 3.1}}) {
    std::vector<double> a;
    for (double x : t) a.push_back(cubic(x));
    const SampledAcceleration s(t, a, Interpolation::kSpline);
    for (double x = t.front(); x <= t.back(); x += 0.01) EXPECT_NEAR(s.TableAcceleration(x), cubic(x), 1e-12 * 10) << x;
    EXPECT_EQ(s.TableAcceleration(t.back() + 0.01), 0.0);
  }
  std::vector<double> t, a;
  for (int k = 0; k <= 8; ++k) {
    t.push_back(0.25 * k);
    a.push_back(quadratic(0.25 * k));
  }
  const SampledAcceleration cr(t, a, Interpolation::kCatmullRom);
  for (double x = t[1]; x <= t[7]; x += 0.01) EXPECT_NEAR(cr.TableAcceleration(x), quadratic(x), 1e-12 * 10) << x;
  const SampledAcceleration two({0.0, 2.0}, {1.0, 3.0}, Interpolation::kSpline);
  EXPECT_DOUBLE_EQ(two.TableAcceleration(0.5), 1.5);
  const SampledAcceleration three({0.0, 1.0, 3.0}, {0.0, 1.0, 0.0}, Interpolation::kSpline);
  EXPECT_NEAR(three.TableAcceleration(0.5), 0.59375, 1e-15);
}

// ORACLE: the interpolants' error on a(t) = sin(2 pi f t) (f = 3.3 Hz,
// figure 7's table) sampled at 1 kHz and 250 Hz over 1 s, against its
// closed form: the chord's is h^2 / 8 max|a''| mid-interval (within 2 %,
// its next term is O(h^4)); the spline's at most 5/384 h^4 max|a''''|
// four intervals or more from the ends (the clamped spline's bound), and
// over the whole record within 2.2 times it (the not-a-knot end intervals:
// measured 2.08 and 2.11 times, fourth order); Catmull-Rom's at most
// 0.016 h^3 max|a'''| (its one-sided end intervals left out).
TEST(ExcitationTest, InterpolationErrorsOnASineAreTheirBounds) {
  const double w = 2 * 3.14159265358979323846 * 3.3;
  for (double rate : {1000.0, 250.0}) {
    const double h = 1.0 / rate;
    std::vector<double> t, a;
    for (int k = 0; k <= static_cast<int>(rate); ++k) {
      t.push_back(k * h);
      a.push_back(std::sin(w * k * h));
    }
    const SampledAcceleration chord(t, a), spline(t, a, Interpolation::kSpline),
        cr(t, a, Interpolation::kCatmullRom);
    double e_chord = 0, e_spline = 0, e_spline_inside = 0, e_cr = 0;
    for (double x = 0.0; x <= 1.0; x += h / 16) {
      e_chord = std::max(e_chord, std::abs(chord.TableAcceleration(x) - std::sin(w * x)));
      e_spline = std::max(e_spline, std::abs(spline.TableAcceleration(x) - std::sin(w * x)));
      if (x >= 4 * h && x <= 1.0 - 4 * h) {
        e_spline_inside = std::max(e_spline_inside, std::abs(spline.TableAcceleration(x) - std::sin(w * x)));
      }
      if (x >= h && x <= 1.0 - h) e_cr = std::max(e_cr, std::abs(cr.TableAcceleration(x) - std::sin(w * x)));
    }
    const double chord_bound = h * h / 8 * w * w, spline_bound = 5.0 / 384 * std::pow(h * w, 4),
                 cr_bound = 0.016 * std::pow(h * w, 3);
    std::printf("%g Hz: chord %.3e (h^2/8 a'' %.3e), spline %.3e, inside %.3e (bound %.3e), Catmull-Rom %.3e "
                "(bound %.3e)\n",
                rate, e_chord, chord_bound, e_spline, e_spline_inside, spline_bound, e_cr, cr_bound);
    EXPECT_NEAR(e_chord / chord_bound, 1.0, 0.02) << rate;
    EXPECT_LE(e_spline_inside, spline_bound) << rate;
    EXPECT_LE(e_spline, 2.2 * spline_bound) << rate;
    EXPECT_LE(e_cr, cr_bound) << rate;
  }
}

std::string ScratchPrefix() { return test::ScratchDir("excitation_test") + "/"; }

std::string ExcitationCsvError(const std::string& name, const std::string& text) {
  const std::string path = ScratchPrefix() + name;
  std::ofstream(path) << text;
  try {
    ReadAccelerationCsv(path);
  } catch (const std::runtime_error& e) {
    std::remove(path.c_str());
    return e.what();
  }
  std::remove(path.c_str());
  return "";
}

// ORACLE: the contract "FILE:LINE: ..." for each kind of bad file.
TEST(ExcitationTest, CsvReaderNamesFileAndLine) {
  const std::string path = ScratchPrefix() + "good.csv";
  std::ofstream(path) << "time,accel\n0,0\n0.5,1\n1.0,-1\n";
  const SampledAcceleration s = ReadAccelerationCsv(path);
  EXPECT_DOUBLE_EQ(s.TableAcceleration(0.75), 0.0);
  EXPECT_EQ(s.end_s(), 1.0);
  std::remove(path.c_str());

  const std::string dir = ScratchPrefix();
  EXPECT_EQ(ExcitationCsvError("ragged.csv", "time,accel\n0,1\n1,2,3\n"),
            dir + "ragged.csv:3: expected 2 fields (time,accel), got '1,2,3'");
  EXPECT_NE(ExcitationCsvError("text.csv", "time,accel\n0,1\n1,abc\n").find("text.csv:3: accel 'abc'"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("nan.csv", "time,accel\n0,1\n1,nan\n").find("nan.csv:3:"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("order.csv", "time,accel\n0,1\n1,2\n1,3\n").find("order.csv:4: time"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("empty.csv", "").find("empty.csv:1: empty file"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("header.csv", "t,a\n0,1\n").find("header.csv:1: header"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("short.csv", "time,accel\n0,1\n").find("short.csv:2:"), std::string::npos);
  EXPECT_NE(ExcitationCsvError("missing.csv", "x").find("missing.csv"), std::string::npos);
}

// Oracle: the definition of a sum (the parts' accelerations add; the next
// jump is the earliest of the parts') on a sine and a two-sample record.
TEST(ExcitationTest, ForcingSumAddsAnyKindOfPart) {
  std::vector<std::unique_ptr<Forcing>> parts;
  parts.push_back(MakeSine({0.006, 2.0, 3.0, 0.5}));
  parts.push_back(std::make_unique<SampledAcceleration>(std::vector<double>{1.0, 2.0},
                                                        std::vector<double>{0.0, 4.0}));
  const Forcing* sine = parts[0].get();
  const Forcing* record = parts[1].get();
  const double at[] = {0.2, 1.25, 1.9, 2.6};
  double sine_a[4];
  double record_a[4];
  for (int k = 0; k < 4; ++k) {
    sine_a[k] = sine->TableAcceleration(at[k]);
    record_a[k] = record->TableAcceleration(at[k]);
  }
  const auto sum = MakeForcingSum(std::move(parts));
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(sum->TableAcceleration(at[k]), sine_a[k] + record_a[k]);
  EXPECT_EQ(sum->NextDiscontinuity(0.0), 0.5);  // the sine starts
  EXPECT_EQ(sum->NextDiscontinuity(0.5), 1.0);  // the record starts
  EXPECT_EQ(sum->NextDiscontinuity(2.0), 3.5);  // the sine ends
  std::vector<std::unique_ptr<Forcing>> with_null(1);
  EXPECT_THROW(MakeForcingSum(std::move(with_null)), std::invalid_argument);
}

// Oracle: the reader's contract: comments and blank lines skipped, blanks
// around fields allowed, every row's own line number kept; bad bytes are
// quoted escaped (one ASCII line whatever the file holds).
TEST(ExcitationTest, CsvReaderSkipsCommentsAndKeepsLines) {
  const std::string path = ScratchPrefix() + "commented.csv";
  std::ofstream(path) << "# table record\n\n time , accel \n0, 0.5\n# pause\n0.25 ,-1\n";
  const AccelerationRows rows = ReadAccelerationRows(path);
  EXPECT_EQ(rows.time_s, (std::vector<double>{0.0, 0.25}));
  EXPECT_EQ(rows.accel_mps2, (std::vector<double>{0.5, -1.0}));
  EXPECT_EQ(rows.line, (std::vector<std::int64_t>{4, 6}));
  std::remove(path.c_str());
  EXPECT_NE(ExcitationCsvError("binary.csv", std::string("time,accel\n0,1\n1,\x01\xff\n")).find("accel '\\x01\\xff'"),
            std::string::npos);
}

}  // namespace
}  // namespace rocklab::model
