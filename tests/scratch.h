#pragma once
// The one scratch folder helper of the tests: a folder unique to this build
// tree and this process, so neither two builds (CI and a developer's, two
// worktrees) nor two tests that ctest runs at once (`ctest -j`, every test
// case in its own process) write the same files. Never the system temp
// folder under a fixed name.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
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

/// A file's bytes ("" when it cannot be read).
inline std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// The names in a folder (what a writer left there).
inline std::set<std::string> Listing(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

}  // namespace rocklab::test
