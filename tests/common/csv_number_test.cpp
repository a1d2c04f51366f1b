// common/csv_number.h: the reconstruct CSV's numbers written without printf.
// Oracle: glibc's snprintf with the same format ("%.12g", "%.9f"), byte for
// byte, on values of every magnitude the fast path takes and around its
// edges; where the fast path declines (nullptr) the caller's std::to_chars
// is printf's conversion by the standard's definition, so only the
// declining is checked there.
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "common/csv_number.h"

namespace rocklab::common {
namespace {

std::string Printf(const char* format, double x) {
  char buf[512];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

// The fast path's text, or "" where it declines.
std::string General(double x) {
  char buf[64];
  char* end = csv_number::General12(x, buf);
  return end ? std::string(buf, static_cast<std::size_t>(end - buf)) : std::string();
}
std::string Fixed(double x) {
  char buf[64];
  char* end = csv_number::Fixed9(x, buf);
  return end ? std::string(buf, static_cast<std::size_t>(end - buf)) : std::string();
}

// Whether x's exact decimal expansion (printf prints it whole with enough
// digits) is a tie at its 12th significant digit: "5" then only zeros.
bool TieAt12(double x) {
  const std::string e = Printf("%.300e", x);
  const std::size_t at = e.find('.') + 12;  // first digit after the 12th significant one
  return e[at] == '5' && e.find_first_not_of('0', at + 1) == e.find('e');
}

// Every value: the fast path's text is printf's, or it declines. Counts the
// values %.12g took, and those it declined that are not exact ties.
void Expect(double x, int& taken, int* declined = nullptr) {
  const std::string g = General(x);
  if (!g.empty()) {
    ++taken;
    ASSERT_EQ(g, Printf("%.12g", x)) << "x = " << Printf("%.17g", x);
  } else if (declined && !TieAt12(x)) {
    ++*declined;
  }
  const std::string f = Fixed(x);
  if (!f.empty()) {
    ASSERT_EQ(f, Printf("%.9f", x)) << "x = " << Printf("%.17g", x);
  }
}

TEST(CsvNumber, MatchesPrintfOverMagnitudes) {
  std::mt19937_64 rng(15);
  std::uniform_real_distribution<double> mantissa(1.0, 10.0);
  for (int e = -14; e <= 17; ++e) {
    int taken = 0;
    int declined = 0;
    for (int i = 0; i < 4000; ++i) {
      const double x = mantissa(rng) * std::pow(10.0, e) * (i % 2 ? -1 : 1);
      Expect(x, taken, &declined);
    }
    // %.12g: the fast path takes every value in [1e-11, 1e12) but exact ties
    // (printf's rounding of a tie is left to to_chars), none beyond 1e13.
    if (e >= -11 && e <= 11) {
      EXPECT_EQ(declined, 0) << "1e" << e;
    }
    if (e < -12 || e > 12) {
      EXPECT_EQ(taken, 0) << "1e" << e;
    }
  }
}

TEST(CsvNumber, MatchesPrintfAtRoundingAndStyleEdges) {
  int taken = 0;
  // Decimal values printf must round at the 12th digit or the 9th decimal,
  // the carries 9.99...e-k -> 1e-k+1, the %g style switches at 1e-4 and 1e12,
  // and each double's neighbours.
  const double values[] = {0.1, 0.5, 1.0, 9.9999999999995, 9.99999999999949, 0.000099999999999995,
                           0.0001, 0.00009999999999999, 1e-5, 123456789012.5, 999999999999.5,
                           999999999999.4, 1e11, 1e12, 599.999, 0.001, 0.0105, 1.0000000000005,
                           2.5e-9, 0.0000000005, 0.0000000015, 1e-11, 9.999999999999999e-12,
                           4503599627370495.5, 3.14159265358979, 2.718281828459045, 0.30000000000000004};
  for (double v : values) {
    for (double x = std::nextafter(v, 0.0), i = 0; i < 3; ++i, x = std::nextafter(x, 1e300)) {
      Expect(x, taken);
      Expect(-x, taken);
    }
  }
  // The times of a 1 kHz record (k / 1000 s) and their sums as a reader makes them.
  double t = 0;
  for (int k = 0; k < 200000; ++k) {
    Expect(k / 1000.0, taken);
    Expect(t, taken);
    t += 0.001;
  }
  EXPECT_GT(taken, 200000);
}

TEST(CsvNumber, DeclinesWhatItCannotDoExactly) {
  for (double x : {0.0, -0.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity(), std::numeric_limits<double>::denorm_min(), 1e300,
                   4503599627370496.0, 1e-300}) {
    EXPECT_EQ(General(x), "") << x;
    EXPECT_EQ(Fixed(x), "") << x;
  }
  // 2^-10 = 0.0009765625 is an exact tie at the 9th decimal (printf: "0.000976562").
  EXPECT_EQ(Fixed(0.0009765625), "");
  EXPECT_EQ(Fixed(0.0009765625 + 1e-15), "0.000976563");
  EXPECT_EQ(General(0.5), "0.5");
  EXPECT_EQ(General(1e-5), "1e-05");
  EXPECT_EQ(General(-123456.5), "-123456.5");
  EXPECT_EQ(Fixed(-1e-12), "-0.000000000");
}

}  // namespace
}  // namespace rocklab::common
