#include <fmt/format.h>

#include <cstdint>
#include <cstring>

#include "common/csv_number.h"

namespace rocklab::common::csv_number {
namespace {

// The number of decimal digits of v >= 1.
inline int DigitCount(uint64_t v) {
  static constexpr uint64_t kPow10[] = {1ULL,
                                        10ULL,
                                        100ULL,
                                        1000ULL,
                                        10000ULL,
                                        100000ULL,
                                        1000000ULL,
                                        10000000ULL,
                                        100000000ULL,
                                        1000000000ULL,
                                        10000000000ULL,
                                        100000000000ULL,
                                        1000000000000ULL,
                                        10000000000000ULL,
                                        100000000000000ULL,
                                        1000000000000000ULL,
                                        10000000000000000ULL,
                                        100000000000000000ULL,
                                        1000000000000000000ULL,
                                        10000000000000000000ULL};
  // floor(log10 v) from the bit length (1233 / 4096 ~ log10 2), then one
  // comparison to correct it.
  const int bits = 64 - __builtin_clzll(v);
  const int guess = (bits * 1233) >> 12;
  return guess + (v >= kPow10[guess] ? 1 : 0);
}

// The 8 digits of v < 10^8 (zero-padded) at out, two at a time.
inline void Digits8(uint32_t v, char* out) {
  const char* pairs = detail::DigitPairs();
  const uint32_t high = v / 10000;
  const uint32_t low = v % 10000;
  std::memcpy(out, pairs + 2 * (high / 100), 2);
  std::memcpy(out + 2, pairs + 2 * (high % 100), 2);
  std::memcpy(out + 4, pairs + 2 * (low / 100), 2);
  std::memcpy(out + 6, pairs + 2 * (low % 100), 2);
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
  // The 17 digits of sig < 10^17, zero-padded, in three parts (no 64-bit
  // division in a loop); its n digits are the last n. The copies below
  // move fixed sizes (whole words) past the n digits, which the later
  // writes overwrite or the returned end excludes.
  const int n = DigitCount(sig);
  char padded[48]{};  // zeros past the digits: the fixed-size copies read only set bytes
  padded[0] = static_cast<char>('0' + sig / 10000000000000000ULL);
  const uint64_t rest = sig % 10000000000000000ULL;
  Digits8(static_cast<uint32_t>(rest / 100000000), padded + 1);
  Digits8(static_cast<uint32_t>(rest % 100000000), padded + 9);
  const char* digits = padded + 17 - n;
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

}  // namespace rocklab::common::csv_number
