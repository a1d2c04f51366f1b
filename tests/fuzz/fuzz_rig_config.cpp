// Fuzz target: the rig file parser (TOML and every value check), then the
// set-up the values drive: a Processor (its Savitzky-Golay differentiators)
// over the rig's own channels.
// Invariants: only std::runtime_error (naming the file) escapes the parser;
// an accepted rig's differentiators are within their bounds, and a Processor
// is built from it without an exception.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/savitzky_golay.h"
#include "tests/fuzz/fuzz_util.h"

using namespace rocklab::daq;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  RigConfig rig;
  try {
    rig = ParseRigConfig(text, "fuzz.toml");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz.toml", 0) != 0) rocklab::fuzz::Violated("message without the file", e.what());
    return 0;
  }
  for (const DifferentiatorConfig* d : {&rig.theta_dot, &rig.table}) {
    const int m = rig.HalfWindow(*d);
    if (m < 1 || m > kMaxHalfWindowSamples || d->order < 2 || d->order > 6 || 2 * m + 1 <= d->order) {
      rocklab::fuzz::Violated("differentiator out of its bounds");
    }
  }
  std::vector<std::string> names;
  for (const ChannelConfig& c : rig.channels) names.push_back(c.name);
  ProcessorSink sink;
  try {
    Processor processor(rig, names, "fuzz.csv", sink);
  } catch (const std::exception& e) {
    rocklab::fuzz::Violated("an accepted rig does not build a Processor", e.what());
  }
  return 0;
}
