// Fuzz target: a PEER NGA .AT2 record through the one table-acceleration
// reader (model::ReadAccelerationRows, by extension). Input: the file's
// bytes, written to a scratch file of this process (the reader takes a path).
// Invariants: it returns or throws std::runtime_error with one bounded line
// of printable ASCII naming the file; what it returns has equal-length
// columns, at least 2 samples, finite values and strictly increasing time.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>

#include "model/excitation.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rocklab::fuzz::WriteScratch("at2.AT2", data, size);
  try {
    const rocklab::model::AccelerationRows rows = rocklab::model::ReadAccelerationRows(path);
    if (rows.time_s.size() != rows.accel_mps2.size() || rows.time_s.size() != rows.line.size()) {
      rocklab::fuzz::Violated("columns of different lengths");
    }
    if (rows.time_s.size() < 2) rocklab::fuzz::Violated("fewer than 2 samples returned");
    for (std::size_t i = 0; i < rows.time_s.size(); ++i) {
      if (!std::isfinite(rows.time_s[i]) || !std::isfinite(rows.accel_mps2[i])) {
        rocklab::fuzz::Violated("a non-finite sample returned");
      }
      if (i > 0 && !(rows.time_s[i] > rows.time_s[i - 1])) rocklab::fuzz::Violated("time not increasing");
    }
  } catch (const std::runtime_error& e) {
    rocklab::fuzz::CheckMessage(e.what(), 4096);
  }
  return 0;
}
