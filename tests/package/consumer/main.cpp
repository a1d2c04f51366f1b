// A consumer of the installed rocklab: block parameters (model), an LCM
// message (the generated types), the comparator (compare), a rig file
// (daq), a record (model/record.h, model/fit.h), a fragility fit (sweep)
// and the log sniffer (export), through the exported targets only. Exits 0 when every check holds, 1 with a message otherwise.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "compare/comparator.h"
#include "daq/rig_config.h"
#include "export/export.h"
#include "model/block.h"
#include "model/fit.h"
#include "model/record.h"
#include "rocklab/block_state_t.hpp"
#include "sweep/fragility.h"

namespace {

int failures = 0;

void Check(bool ok, const std::string& what) {
  if (!ok) {
    std::fprintf(stderr, "consumer: FAILED: %s\n", what.c_str());
    ++failures;
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Oracle: closed forms for a rectangle 2b x 2h (Housner): alpha =
  // atan(b/h), R = sqrt(b^2 + h^2), I_O/M = 4 R^2 / 3, p = sqrt(3 g / (4 R)).
  // Block 1 of the paper's Table 1: 0.247 m x 1.0 m. Tolerance 1e-12
  // relative: the same double formulas in another order.
  const double b = 0.247 / 2, h = 1.0 / 2, g = rocklab::model::kGravity;
  const rocklab::model::BlockGeometry block = rocklab::model::RectangleBlock(0.247, 1.0);
  const double R = std::hypot(b, h);
  Check(std::fabs(block.alpha - std::atan(b / h)) < 1e-12, "alpha = atan(b/h)");
  Check(std::fabs(block.p - std::sqrt(3 * g / (4 * R))) < 1e-12 * block.p, "p = sqrt(3g/4R)");

  // An RL_THETA message round trip through the installed generated header.
  rocklab::block_state_t out{};
  out.utime = 1234567;
  out.theta = 0.0125;
  std::vector<unsigned char> bytes(static_cast<std::size_t>(out.getEncodedSize()));
  Check(out.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()),
        "block_state_t encodes");
  rocklab::block_state_t in{};
  Check(in.decode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()) &&
            in.utime == out.utime && in.theta == out.theta,
        "block_state_t decodes to what was encoded");

  // The comparator. Oracle: a model 0.001 rad above the measurement at
  // every sample has an RMS error of exactly 0.001 rad (to 1e-12).
  rocklab::compare::Comparator comparator;
  for (int i = 0; i < 500; ++i) {
    const double measured = 0.01 * std::sin(2 * M_PI * i / 100.0);
    comparator.Add(std::int64_t{1000} * i, measured, measured + 0.001, true);
  }
  Check(std::fabs(comparator.metrics().rms_total - 0.001) < 1e-12, "rms_total of a 1 mrad offset");

  // The installed rig file reads (share/rocklab/rigs/lab_rig.toml, passed
  // by the test).
  if (argc > 1) {
    const rocklab::daq::RigConfig rig = rocklab::daq::LoadRigConfig(argv[1]);
    Check(!rig.name.empty(), std::string("rig name of ") + argv[1]);
  }

  // model/record.h and model/fit.h: a record made in memory passes the
  // record checks' gap count (no holes: 0 missing samples).
  rocklab::model::RockingRecord record;
  for (int i = 0; i < 100; ++i) {
    record.time_s.push_back(i * 1e-3);
    record.theta.push_back(0.0);
    record.line.push_back(i + 2);
  }
  const rocklab::model::GapCount gaps = rocklab::model::CountGaps(record.time_s, record.line);
  Check(gaps.missing_samples == 0 && gaps.gaps == 0, "no gaps in a regular record");

  // sweep: a lognormal fragility fit. Oracle: outcomes symmetric in ln x
  // about x = 1 (2/10 at 0.5, 5/10 at 1, 8/10 at 2) put the likelihood's
  // maximum at median 1 exactly (a = 0 by symmetry); 1e-9 relative covers
  // the Newton iteration's stopping test (1e-13 on the step).
  const rocklab::sweep::FragilityFit fit =
      rocklab::sweep::FitLognormalFragility({{0.5, 10, 2}, {1.0, 10, 5}, {2.0, 10, 8}});
  Check(fit.status == rocklab::sweep::FragilityFit::Status::kFitted && std::fabs(fit.median - 1.0) < 1e-9,
        "fragility median of symmetric outcomes is 1");

  // export: a TOML file is not an LCM log.
  if (argc > 1) Check(!rocklab::exporter::IsLcmLog(argv[1]), "a rig file is not an LCM log");

  if (failures == 0) std::printf("consumer: every check holds\n");
  return failures == 0 ? 0 : 1;
}
