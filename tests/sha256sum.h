#pragma once
// coreutils' sha256sum of a file: the tests' SHA-256, independent of
// rocklab's own (common/provenance.h).

#include <cstdio>
#include <string>

namespace rocklab::test {

/// The 64 hex digits `sha256sum PATH` prints; "" when it cannot run.
inline std::string Sha256sum(const std::string& path) {
  std::FILE* pipe = ::popen(("sha256sum '" + path + "'").c_str(), "r");
  if (pipe == nullptr) return "";
  char hash[65] = {};
  const std::size_t n = std::fread(hash, 1, 64, pipe);
  ::pclose(pipe);
  return n == 64 ? std::string(hash, 64) : "";
}

}  // namespace rocklab::test
