#pragma once
// Shared by the fuzz targets: a failed invariant stops the run as a crash
// (libFuzzer saves the input), whatever NDEBUG says.

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace rocklab::fuzz {

[[noreturn]] inline void Violated(const char* what, std::string_view detail = {}) {
  std::fprintf(stderr, "fuzz invariant violated: %s: %.*s\n", what, static_cast<int>(detail.size()),
               detail.data());
  std::abort();
}

/// A message shown to a user: one line of printable ASCII (inputs are quoted
/// escaped, docs/reliability.md), and bounded in size.
inline void CheckMessage(std::string_view message, std::size_t max_bytes = 2048) {
  if (message.size() > max_bytes) Violated("message longer than the bound", message.substr(0, 200));
  for (unsigned char c : message) {
    if (c < 0x20 || c > 0x7e) Violated("message with a byte that is not printable ASCII", message);
  }
}

/// The path of this process's scratch file `name`,
/// /tmp/rocklab_fuzz_PID_`name`, removed when the process exits normally
/// (a fuzzer's run ending, a replay done; a crash leaves it beside its input).
inline std::string ScratchPath(const std::string& name) {
  struct Registry {
    std::vector<std::string> paths;
    ~Registry() {
      for (const std::string& path : paths) std::remove(path.c_str());
    }
  };
  static Registry registry;
  std::string path = "/tmp/rocklab_fuzz_" + std::to_string(::getpid()) + "_" + name;
  if (std::find(registry.paths.begin(), registry.paths.end(), path) == registry.paths.end()) {
    registry.paths.push_back(path);
  }
  return path;
}

/// Writes the input to this process's scratch file `name` (ScratchPath) and
/// returns its path (for readers that take a path).
inline std::string WriteScratch(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::string path = ScratchPath(name);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace rocklab::fuzz
