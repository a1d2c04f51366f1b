// common/csv_number.h: the reconstruct CSV's numbers written without printf.
// Oracle: glibc's snprintf with the same format ("%.12g", "%.9f"), byte for
// byte, on values of every magnitude the fast path takes and around its
// edges; where the fast path declines (nullptr) the caller's std::to_chars
// is printf's conversion by the standard's definition, so only the
// declining is checked there. Shortest (simulate's CSV): libstdc++'s
// std::to_chars(first, last, double), byte for byte, and a read back by
// strtod to the same bits.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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

// A fast path's text, or "" where it declines.
std::string FastText(char* (*write)(double, char*), double x) {
  char buf[64];
  char* end = write(x, buf);
  return end ? std::string(buf, static_cast<std::size_t>(end - buf)) : std::string();
}
std::string General(double x) { return FastText(csv_number::General12, x); }
std::string Fixed(double x) { return FastText(csv_number::Fixed9, x); }

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

// Shortest's text (or "" where it declines) and to_chars' text.
std::string Shortest(double x) { return FastText(csv_number::Shortest, x); }
std::string ToChars(double x) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

// Checks one value; counts the ones Shortest wrote.
void ExpectShortest(double x, int& taken) {
  const std::string ours = Shortest(x);
  if (ours.empty()) return;
  ++taken;
  ASSERT_EQ(ours, ToChars(x)) << "bits " << std::hex << [&] {
    uint64_t b = 0;
    std::memcpy(&b, &x, sizeof b);
    return b;
  }();
  ASSERT_EQ(std::strtod(ours.c_str(), nullptr), x) << ours;
}

TEST(CsvNumber, ShortestIsToCharsByteForByte) {
  int taken = 0;
  std::mt19937_64 rng(20261128);
  // Every bit pattern of a normal double below 2^53, uniformly in its bits
  // (so every exponent from 2^-1022 up).
  for (int i = 0; i < 300000; ++i) {
    uint64_t bits = rng() & ~(uint64_t{0x7ff} << 52);
    bits |= static_cast<uint64_t>(1 + rng() % (1023 + 52)) << 52;
    double x = 0;
    std::memcpy(&x, &bits, sizeof x);
    ExpectShortest(x, taken);
  }
  // Short decimals of every magnitude, where the choice between fixed and
  // scientific is close (1e-05 against 0.00001, 1.2e+15 against the integer).
  std::uniform_int_distribution<int> digits(1, 17);
  for (int i = 0; i < 200000; ++i) {
    const int n = digits(rng);
    const double mantissa = static_cast<double>(rng() % static_cast<uint64_t>(std::pow(10.0, n)));
    const int e = static_cast<int>(rng() % 60) - 40;
    const double x = std::strtod((std::to_string(static_cast<uint64_t>(mantissa)) + "e" + std::to_string(e)).c_str(),
                                 nullptr);
    ExpectShortest(x, taken);
    ExpectShortest(-x, taken);
  }
  // What simulate writes: times k / rate and sums of steps, angles and rates.
  for (int k = 0; k < 200000; ++k) {
    ExpectShortest(k / 200.0, taken);
    ExpectShortest(k * 0.005, taken);
    ExpectShortest(1e-3 * std::sin(k * 0.01), taken);
  }
  for (int e = -307; e <= 15; ++e) {
    const double p = std::pow(10.0, e);
    for (double x : {p, std::nextafter(p, 0.0), std::nextafter(p, 1e300), 5 * p, 0.5 * p}) ExpectShortest(x, taken);
  }
  for (double x : {1.0, 2.0, 9007199254740991.0, 4503599627370496.5, 0.1, 0.3, 1e-5, 1e-4, 1.5e-4, 123456.0,
                   1e15, 1.2e15, 100.0, 1e16 / 3})
    ExpectShortest(x, taken);
  EXPECT_GT(taken, 1200000);
}

TEST(CsvNumber, ShortestDeclinesWhatToCharsMustWrite) {
  for (double x : {0.0, -0.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity(), std::numeric_limits<double>::denorm_min(),
                   9007199254740992.0, 1e300, -1e17})
    EXPECT_EQ(Shortest(x), "") << x;
  EXPECT_EQ(Shortest(1e-5), "1e-05");
  EXPECT_EQ(Shortest(0.00012), "0.00012");
  EXPECT_EQ(Shortest(-1e15), "-1e+15");
  EXPECT_EQ(Shortest(123456789012345.0), "123456789012345");
  EXPECT_EQ(Shortest(2.5e-300), "2.5e-300");
  EXPECT_EQ(Shortest(0.005), "0.005");
}

}  // namespace
}  // namespace rocklab::common
