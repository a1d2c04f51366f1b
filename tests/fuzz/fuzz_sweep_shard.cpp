// Fuzz targets sweep_csv and sweep_h5 (ROCKLAB_FUZZ_SWEEP_H5): a sweep's
// results file, CSV or HDF5, through every reader of it: sweep-plot's and
// info's sweep::ReadResults, and `sweep --merge` (sweep::MergeShards) of
// it as the one shard of a fixed two-case plan (record r.csv of samples
// (0 s, 0) and (1 s, 1 m/s^2), alpha 0.2 rad, p 3 rad/s, mu 0.94, scales
// 1:2:2, --duration 3: `rocklab sweep --records r.csv --alpha 0.2 --p 3
// --mu 0.94 --scale 1:2:2 --duration 3 --model housner`, which wrote the
// seeds). Input: the file's bytes, written to a scratch file of this
// process (the readers take a path; HDF5 opens files only).
// Invariants: each reader returns or throws std::runtime_error with one
// bounded line of printable ASCII; ReadResults returns only rows that
// sweep::RowProblem takes; a merge that succeeds wrote a file ReadResults
// reads back whole (a merge never writes a row sweep-plot refuses).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>

#include "sweep/plot.h"
#include "sweep/runner.h"
#include "sweep/sweep.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using namespace rocklab;

sweep::Plan FuzzPlan() {
  sweep::Plan p;
  sweep::Record r;
  r.path = r.name = "r.csv";  // lint: name-ok: the record's name in the rows, never opened
  r.time_s = {0.0, 1.0};
  r.accel_mps2 = {0.0, 1.0};
  r.pga_mps2 = 1.0;
  p.records = {r};
  p.blocks = {{model::BlockParams{0.2, 3.0, 0.94}, "-"}};
  p.scales = {1.0, 2.0};
  p.duration_s = 3.0;
  return p;
}

void CheckRows(const std::vector<sweep::ResultRow>& rows) {
  for (const sweep::ResultRow& r : rows) {
    const std::string problem = sweep::RowProblem(
        {r.scale, r.pga_g, r.alpha, r.p, r.mu, r.peak_theta_over_alpha, r.overturned ? 1.0 : 0.0});
    if (!problem.empty()) fuzz::Violated("ReadResults returned a row RowProblem refuses", problem);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
#ifdef ROCKLAB_FUZZ_SWEEP_H5
  const char* const ext = ".h5";
#else
  const char* const ext = ".csv";
#endif
  static const std::string out = fuzz::ScratchPath("sweep_merged.csv");
  static const sweep::Plan plan = FuzzPlan();
  const std::string path = fuzz::WriteScratch(std::string("sweep") + ext, data, size);
  try {
    CheckRows(sweep::ReadResults(path));
  } catch (const std::runtime_error& e) {
    fuzz::CheckMessage(e.what(), 4096);
  }
  std::remove(out.c_str());
  bool merged = false;
  try {
    sweep::MergeShards(plan, {path}, out);
    merged = true;
  } catch (const std::runtime_error& e) {
    fuzz::CheckMessage(e.what(), 4096);
  }
  if (merged) {
    try {
      const std::vector<sweep::ResultRow> rows = sweep::ReadResults(out);
      if (rows.size() != plan.size()) fuzz::Violated("the merged file does not hold the plan's rows");
    } catch (const std::runtime_error& e) {
      fuzz::Violated("sweep-plot refuses what --merge wrote", e.what());
    }
  }
  return 0;
}
