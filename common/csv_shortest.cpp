#include <fmt/format.h>

#include <charconv>
#include <cstdint>
#include <cstring>

#include "common/csv_number.h"

namespace rocklab::common::csv_number {
namespace {

// The number of decimal digits of v >= 1: floor(log10 v) from the bit
// length (1233 / 4096 ~ log10 2), then one comparison to correct it.
inline int DigitCount(uint64_t v) {
  const int bits = 64 - __builtin_clzll(v);
  const int guess = (bits * 1233) >> 12;  // <= 19
  return guess + (v >= Pow10(guess) ? 1 : 0);
}

}  // namespace

char* Shortest(double x, char* out) {
  uint64_t bits = 0;
  std::memcpy(&bits, &x, sizeof bits);
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  // Zero, subnormals, inf and NaN; |x| >= 2^53, where to_chars' fixed form
  // prints the exact integer rather than the shortest digits.
  if (biased == 0 || biased >= 1023 + 53) return nullptr;
  const auto d = fmt::detail::dragonbox::to_decimal(x);
  uint64_t sig = d.significand;
  int e10 = d.exponent;  // |x| reads back from sig 10^e10
  while (sig % 10 == 0) {  // Dragonbox strips them already; kept as a guard
    sig /= 10;
    ++e10;
  }
  // The 18 digits of sig < 10^17, zero-padded, as 6 and 12 (no 64-bit
  // division in a loop); its n digits are the last n. The copies below
  // move fixed sizes (whole words) past the n digits, which the later
  // writes overwrite or the returned end excludes.
  const int n = DigitCount(sig);
  char padded[48]{};  // zeros past the digits: the fixed-size copies read only set bytes
  detail::Digits6(static_cast<uint32_t>(sig / 1000000000000ULL), padded);
  detail::Digits12(sig % 1000000000000ULL, padded + 6);
  const char* digits = padded + 18 - n;
  const char* pairs = detail::DigitPairs();
  // to_chars' choice: the shorter of scientific and fixed, fixed on a tie.
  const int exp_sci = e10 + n - 1;
  const int abs_sci = exp_sci < 0 ? -exp_sci : exp_sci;
  const int sci_length = n + (n > 1 ? 1 : 0) + 2 + (abs_sci >= 100 ? 3 : 2);
  const int fixed_length = e10 >= 0 ? n + e10 : (exp_sci >= 0 ? n + 1 : n + 1 - exp_sci);
  char* p = out;
  if (bits >> 63) *p++ = '-';
  if (fixed_length <= sci_length) {
    if (e10 >= 0) {  // an integer: the digits, then (at most 5) zeros
      std::memcpy(p, digits, 17);
      std::memset(p + n, '0', 8);
      return p + n + e10;
    }
    if (exp_sci >= 0) {  // ddd.ddd, with at most 16 before the point
      std::memcpy(p, digits, 16);
      p[exp_sci + 1] = '.';
      std::memcpy(p + exp_sci + 2, digits + exp_sci + 1, 16);
      return p + n + 1;
    }
    // 0.000ddd: at most 3 zeros after the point (one more and the
    // scientific form is as short).
    std::memcpy(p, "0.000000", 8);
    std::memcpy(p + 1 - exp_sci, digits, 17);
    return p + 1 - exp_sci + n;
  }
  p[0] = digits[0];
  p[1] = '.';
  std::memcpy(p + 2, digits + 1, 16);
  p += n > 1 ? n + 1 : 1;
  *p++ = 'e';
  *p++ = exp_sci < 0 ? '-' : '+';
  if (abs_sci >= 100) *p++ = static_cast<char>('0' + abs_sci / 100);
  std::memcpy(p, pairs + 2 * (abs_sci % 100), 2);
  return p + 2;
}

char* WriteShortest(double x, char* out) {
  char* end = Shortest(x, out);
  return end != nullptr ? end : std::to_chars(out, out + 48, x).ptr;
}

}  // namespace rocklab::common::csv_number
