#pragma once
// The one scratch folder helper of the tests: a folder unique to this build
// tree and this process, so neither two builds (CI and a developer's, two
// worktrees) nor two tests that ctest runs at once (`ctest -j`, every test
// case in its own process) write the same files. Never the system temp
// folder under a fixed name.

#include <unistd.h>

#include <filesystem>
#include <string>

namespace rocklab::test {

/// `<working directory>/scratch/<name>-<pid>`, created. ctest runs the tests
/// in their folder of the build tree (gtest_discover_tests' WORKING_DIRECTORY).
/// Nobody removes it: what a failed test wrote stays to be read.
inline std::string ScratchDir(const std::string& name) {
  const std::filesystem::path p =
      std::filesystem::current_path() / "scratch" / (name + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  return p.string();
}

}  // namespace rocklab::test
