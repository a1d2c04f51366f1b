// Fuzz target: an assembly file of `simulate --assembly` (TOML and every
// key check, pipeline::ParseAssembly), then what its values build: the
// equivalent single block of a one-body assembly or a frame, or the stack.
// Invariants: only OptionError, naming the file, escapes the parser, on
// one printable line; an accepted stack builds a model::stack::Stack; an
// accepted block or frame has alpha in (0, pi/2), p > 0 and mu in (0, 1].
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/stack.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "tests/fuzz/fuzz_util.h"

using namespace rocklab;

namespace {

// A refusal names the assembly file on one printable line.
void CheckAssemblyRefusal(const pipeline::OptionError& e) {
  if (std::string(e.what()).find("fuzz.toml") == std::string::npos) fuzz::Violated("message without the file", e.what());
  fuzz::CheckMessage(e.what());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  pipeline::Assembly a;
  try {
    a = pipeline::ParseAssembly(text, "fuzz.toml");
  } catch (const pipeline::OptionError& e) {
    CheckAssemblyRefusal(e);
    return 0;
  } catch (const std::exception& e) {
    fuzz::Violated("an exception other than OptionError", e.what());
  }
  if (a.bodies.size() > 1) {
    std::vector<model::stack::Body> bodies;
    for (const pipeline::AssemblyBody& b : a.bodies) {
      if (!(b.width_m > 0 && b.height_m > 0 && b.mass_kg > 0 && std::isfinite(b.mass_kg))) {
        fuzz::Violated("an accepted stack body without a positive size and mass");
      }
      bodies.push_back(model::stack::Body::Rectangle(b.width_m, b.height_m, b.mass_kg));
    }
    try {
      const model::stack::Stack stack(bodies);
    } catch (const std::exception& e) {
      fuzz::Violated("an accepted stack does not build", e.what());
    }
    return 0;
  }
  // A polygon section is read from a file beside the assembly: not here.
  if (!a.bodies.empty() && !a.bodies.front().polygon_csv.empty()) return 0;
  std::optional<model::BlockParams> block;
  try {
    block = pipeline::EquivalentBlock(a);
  } catch (const pipeline::OptionError& e) {
    CheckAssemblyRefusal(e);
    return 0;
  }
  if (!block) fuzz::Violated("a one-body assembly or frame without its single block");
  if (!(block->alpha > 0 && block->alpha < M_PI / 2 && block->p > 0 && std::isfinite(block->p) && block->mu > 0 &&
        block->mu <= 1)) {
    fuzz::Violated("an accepted block or frame with alpha, p or mu out of range");
  }
  return 0;
}
