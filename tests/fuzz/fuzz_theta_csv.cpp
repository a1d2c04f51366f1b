// Fuzz target: a record's `time,theta` CSV (`fit --input`, rocklab.fit)
// through model::ReadRecord, then the impacts method's feature scan
// (model::ExtractFreeRocking) over what it accepts. Input: the file's bytes,
// written to a scratch file of this process (the reader takes a path).
// Invariants: the reader returns or throws model::RecordError with one
// bounded line of printable ASCII naming the file; an accepted record has
// equal-length columns, finite values and strictly increasing time; the scan
// returns (it throws nothing) with impact times inside the record.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "model/fit.h"
#include "model/test_record.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rocklab::fuzz::WriteScratch("theta.csv", data, size);
  using namespace rocklab::model;
  RockingRecord r;
  try {
    r = ReadRecord(path);
  } catch (const RecordError& e) {
    const std::string message = e.what();
    if (message.rfind(path, 0) != 0) rocklab::fuzz::Violated("message without the file", message);
    rocklab::fuzz::CheckMessage(message, 512);
    return 0;
  }
  if (r.time_s.size() != r.theta.size() || r.time_s.size() != r.line.size()) {
    rocklab::fuzz::Violated("columns of different lengths");
  }
  for (std::size_t i = 0; i < r.time_s.size(); ++i) {
    if (!std::isfinite(r.time_s[i]) || !std::isfinite(r.theta[i])) rocklab::fuzz::Violated("a value not finite");
    if (i > 0 && !(r.time_s[i] > r.time_s[i - 1])) rocklab::fuzz::Violated("time not increasing");
  }
  const FreeRockingFeatures f = ExtractFreeRocking(r, {});
  for (double t : f.impact_time_s) {
    if (!(t >= r.time_s.front() - 1.0 && t <= r.time_s.back() + 1.0) && !std::isnan(t)) {
      rocklab::fuzz::Violated("an impact outside the record");
    }
  }
  return 0;
}
