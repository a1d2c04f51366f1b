// Fuzz target: a polygon section's CSV (`params --polygon`, rocklab.
// block_params(polygon=...)) through model::ReadPolygonCsv and
// model::PolygonBlock. Input: the file's bytes, written to a scratch file of
// this process (the reader takes a path).
// Invariants: both return or throw std::invalid_argument with one bounded
// line of printable ASCII naming the file; an accepted file has at least 3
// finite vertices, a line for each, no crossing edges, and a section of
// finite, positive area, radius and p, and a finite mu <= 1 (mu may be 0 or
// below: a section that wide stops dead at its impact, e.g. the right
// triangle (0,0) (1,1) (1,0), whose mu is 0 to rounding; `params` reports it).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "model/block.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rocklab::fuzz::WriteScratch("polygon.csv", data, size);
  using namespace rocklab::model;
  try {
    const PolygonFile file = ReadPolygonCsv(path);
    if (file.vertices_m.size() < 3 || file.vertices_m.size() != file.line.size()) {
      rocklab::fuzz::Violated("fewer than 3 vertices, or not one line each");
    }
    for (const auto& v : file.vertices_m) {
      if (!v.allFinite()) rocklab::fuzz::Violated("a vertex not finite");
    }
    if (FindCrossingEdges(file.vertices_m)) rocklab::fuzz::Violated("crossing edges accepted");
    const BlockGeometry g = PolygonBlock(file);
    if (!(g.area > 0) || !std::isfinite(g.area) || !(g.R > 0) || !std::isfinite(g.R) || !(g.p > 0) ||
        !std::isfinite(g.p) || !std::isfinite(g.mu_general) || !(g.mu_general <= 1 + 1e-12)) {
      rocklab::fuzz::Violated("an accepted section with a bad property");
    }
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    if (message.rfind(path, 0) != 0) rocklab::fuzz::Violated("message without the file", message);
    rocklab::fuzz::CheckMessage(message, 512);
  }
  return 0;
}
