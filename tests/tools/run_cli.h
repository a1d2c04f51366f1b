#pragma once
// Runs the rocklab binary as a user would and captures what it prints.

#include <string>
#include <vector>

namespace rocklab::test {

struct CliResult {
  int exit_code{-1};
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs ROCKLAB_BINARY with `args` (each passed as one argument, no shell).
CliResult RunCli(const std::vector<std::string>& args);

/// A folder of this process under the test's working directory.
std::string ScratchDir(const std::string& name);

std::string ReadFile(const std::string& path);
void WriteFile(const std::string& path, const std::string& text);

}  // namespace rocklab::test
