// Fuzz target: a `rocklab daq --config` TOML file through
// pipeline::ApplyDaqConfigFile. Input: the file's bytes, written
// to a scratch file of this process (the reader takes a path).
// Invariants: it returns or throws OptionError whose message is one bounded
// line of printable ASCII naming the file; a key given "on the command line"
// (here: prefix) is never taken from the file.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

#include "pipeline/pipeline.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rocklab::fuzz::WriteScratch("daq_config.toml", data, size);
  rocklab::pipeline::DaqStageOptions options;
  options.prefix = "CLI_";
  try {
    rocklab::pipeline::ApplyDaqConfigFile(path, options, [](const std::string& key) { return key == "prefix"; });
  } catch (const rocklab::pipeline::OptionError& e) {
    // toml++ quotes the offending text in its descriptions: bounded, but not
    // always ASCII; the file and line come first.
    const std::string what = e.what();
    if (what.rfind(path + ":", 0) != 0 && what.rfind("--config: cannot open", 0) != 0) {
      rocklab::fuzz::Violated("message does not start with the file", what);
    }
    if (what.size() > 4096) rocklab::fuzz::Violated("message longer than the bound", what.substr(0, 200));
  }
  if (options.prefix != "CLI_") rocklab::fuzz::Violated("a key given on the command line was read from the file");
  return 0;
}
