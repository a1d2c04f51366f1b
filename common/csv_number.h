#pragma once
/// @file
/// printf's "%.12g" and "%.9f" of a double, exactly (the same bytes), for the
/// CSV rows of `rocklab reconstruct` (tools/cmd_reconstruct.cpp), at about a
/// quarter of std::to_chars' cost with a precision. (Shortest, at the end,
/// is the shortest round-trip text for `rocklab simulate`.) The digits come from
/// exact integer arithmetic: a double is m 2^e (m < 2^53), so m 10^k < 2^127
/// for k <= 22 and the rounding to the wanted digit is decided on the exact
/// remainder of the shift by -e. What that cannot cover (zero, NaN, inf,
/// subnormals, |x| >= 2^52 or below 1e-11 for %.12g, an exact tie of the
/// rounding) returns nullptr, and the caller uses std::to_chars, which is
/// printf's conversion by definition.

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace rocklab::common::csv_number {

__extension__ typedef unsigned __int128 Uint128;  // GCC and clang; -Wpedantic knows it as an extension

/// 10^k for k in [0, 22].
inline Uint128 Pow10(int k) {
  struct Table {
    Uint128 p[23];
    constexpr Table() : p() {
      p[0] = 1;
      for (int i = 1; i < 23; ++i) p[i] = p[i - 1] * 10;
    }
  };
  static constexpr Table kTable;
  return kTable.p[k];
}

namespace detail {

// |x| = m 2^-s with s > 0 (nullopt-like false for what the fast path leaves
// to to_chars: zero, subnormal, inf, NaN, an integer-valued |x| >= 2^52).
inline bool Decompose(double x, uint64_t& m, int& s, bool& negative) {
  uint64_t bits = 0;
  std::memcpy(&bits, &x, sizeof bits);
  negative = (bits >> 63) != 0;
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  if (biased == 0 || biased == 0x7ff) return false;
  m = (bits & ((uint64_t{1} << 52) - 1)) | (uint64_t{1} << 52);
  s = 1075 - biased;  // x = m 2^-s
  return s > 0 && s < 120;
}

// round(p / 2^s) to nearest; false on an exact tie (printf rounds ties to
// even on the exact value: left to to_chars).
inline bool RoundShift(Uint128 p, int s, Uint128& q) {
  q = p >> s;
  const Uint128 rem = p - (q << s);
  const Uint128 half = static_cast<Uint128>(1) << (s - 1);
  if (rem == half) return false;
  if (rem > half) ++q;
  return true;
}

// "00" .. "99".
inline const char* DigitPairs() {
  static constexpr char kPairs[] =
      "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
      "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
      "8081828384858687888990919293949596979899";
  return kPairs;
}

// The 6 digits of v < 10^6 (zero-padded) at out, two at a time.
inline void Digits6(uint32_t v, char* out) {
  const char* pairs = DigitPairs();
  std::memcpy(out + 4, pairs + 2 * (v % 100), 2);
  v /= 100;
  std::memcpy(out + 2, pairs + 2 * (v % 100), 2);
  v /= 100;
  std::memcpy(out, pairs + 2 * v, 2);
}

// The 12 digits of v < 10^12 (zero-padded) at out: two independent halves.
inline void Digits12(uint64_t v, char* out) {
  Digits6(static_cast<uint32_t>(v / 1000000), out);
  Digits6(static_cast<uint32_t>(v % 1000000), out + 6);
}

}  // namespace detail

/// Writes printf("%.12g", x) at `out` (room for 32 bytes); returns the end,
/// or nullptr where the caller must use std::to_chars (see the top).
inline char* General12(double x, char* out) {
  uint64_t m = 0;
  int s = 0;
  bool negative = false;
  if (!detail::Decompose(x, m, s, negative)) return nullptr;
  // k = 11 - floor(log10 |x|), from the binary exponent (log10 2 =
  // 0.30103...), corrected below when one off.
  const int b = 52 - s;  // |x| in [2^b, 2^(b+1))
  int k = 11 - static_cast<int>(b >= 0 ? b * 0.30102999566398120 : -((-b) * 0.30102999566398120) - 1);
  k = k < 0 ? 0 : (k > 22 ? 22 : k);  // the estimate may be one off at the ends of the range
  constexpr uint64_t kLow = 100000000000ULL;   // 1e11
  constexpr uint64_t kHigh = 1000000000000ULL;  // 1e12
  Uint128 q = 0;
  for (int attempt = 0;; ++attempt) {
    if (k < 0 || k > 22 || attempt == 3) return nullptr;
    const Uint128 p = static_cast<Uint128>(m) * Pow10(k);
    const Uint128 floor_q = p >> s;
    if (floor_q < kLow) {
      ++k;
      continue;
    }
    if (floor_q >= kHigh) {
      --k;
      continue;
    }
    if (!detail::RoundShift(p, s, q)) return nullptr;
    break;
  }
  // The rounded value is q 10^-k with q in [1e11, 1e12]; its decimal
  // exponent X decides the style (C's %g: fixed when -4 <= X < 12).
  int exp10 = 11 - k;
  if (q == kHigh) {
    q = kLow;
    ++exp10;
  }
  char digits[12];
  detail::Digits12(static_cast<uint64_t>(q), digits);
  int n = 12;
  while (n > 1 && digits[n - 1] == '0') --n;  // %g drops trailing zeros
  char* p = out;
  if (negative) *p++ = '-';
  if (exp10 >= -4 && exp10 < 12) {
    if (exp10 >= 0) {
      std::memcpy(p, digits, static_cast<std::size_t>(exp10 + 1));
      p += exp10 + 1;
      if (n > exp10 + 1) {
        *p++ = '.';
        std::memcpy(p, digits + exp10 + 1, static_cast<std::size_t>(n - exp10 - 1));
        p += n - exp10 - 1;
      }
    } else {
      *p++ = '0';
      *p++ = '.';
      for (int i = 0; i < -exp10 - 1; ++i) *p++ = '0';
      std::memcpy(p, digits, static_cast<std::size_t>(n));
      p += n;
    }
    return p;
  }
  *p++ = digits[0];
  if (n > 1) {
    *p++ = '.';
    std::memcpy(p, digits + 1, static_cast<std::size_t>(n - 1));
    p += n - 1;
  }
  *p++ = 'e';
  *p++ = exp10 < 0 ? '-' : '+';
  const int e = exp10 < 0 ? -exp10 : exp10;
  if (e >= 100) *p++ = static_cast<char>('0' + e / 100);
  *p++ = static_cast<char>('0' + e / 10 % 10);
  *p++ = static_cast<char>('0' + e % 10);
  return p;
}

/// Writes printf("%.9f", x) at `out` (room for 32 bytes); returns the end,
/// or nullptr where the caller must use std::to_chars (see the top; also
/// |x| >= 2^52).
inline char* Fixed9(double x, char* out) {
  uint64_t m = 0;
  int s = 0;
  bool negative = false;
  if (!detail::Decompose(x, m, s, negative)) return nullptr;
  Uint128 q = 0;
  if (!detail::RoundShift(static_cast<Uint128>(m) * 1000000000U, s, q)) return nullptr;
  const uint64_t whole = static_cast<uint64_t>(q / 1000000000U);
  const uint64_t frac = static_cast<uint64_t>(q % 1000000000U);
  char* p = out;
  if (negative) *p++ = '-';
  char digits[20];
  int n = 0;
  uint64_t w = whole;
  do {
    digits[19 - n++] = static_cast<char>('0' + w % 10);
    w /= 10;
  } while (w != 0);
  std::memcpy(p, digits + 20 - n, static_cast<std::size_t>(n));
  p += n;
  *p++ = '.';
  char nine[12];
  detail::Digits12(frac, nine);  // frac < 10^9: three leading zeros
  std::memcpy(p, nine + 3, 9);
  return p + 9;
}

/// Writes the shortest text that reads back as x, the same bytes as
/// std::to_chars(first, last, x) (scientific or fixed, whichever is
/// shorter, fixed on a tie), at `out` (room for 48 bytes: it writes whole
/// words past the text); returns the end,
/// or nullptr where the caller must use std::to_chars (zero, subnormals,
/// inf, NaN, |x| >= 2^53). The digits are fmt's Dragonbox (the same
/// shortest, nearest digits as to_chars' Ryu), at about a quarter of
/// to_chars' cost (csv_shortest.cpp; docs/performance.md).
char* Shortest(double x, char* out);

/// Shortest, or std::to_chars where Shortest declines: the shortest text
/// that reads back as x, always written (room for 48 bytes); returns the end.
char* WriteShortest(double x, char* out);

}  // namespace rocklab::common::csv_number
