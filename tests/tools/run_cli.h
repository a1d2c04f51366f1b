#pragma once
// Runs the rocklab binary as a user would and captures what it prints.

#include <sys/types.h>

#include <functional>
#include <string>
#include <vector>

#include "tests/scratch.h"  // ScratchDir

namespace rocklab::test {

struct CliResult {
  int exit_code{-1};
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs ROCKLAB_BINARY with `args` (each passed as one argument, no shell).
CliResult RunCli(const std::vector<std::string>& args);

/// Starts `argv` (argv[0] found on PATH) in the background, its stdout and
/// stderr into the two files; returns its pid (the caller waits for it).
pid_t StartProcess(const std::vector<std::string>& argv, const std::string& out_path,
                   const std::string& err_path);
/// StartProcess of ROCKLAB_BINARY with `args`.
pid_t StartCli(const std::vector<std::string>& args, const std::string& out_path,
               const std::string& err_path);

/// Sends `signal` (0: none) to `pid` and waits for it, at most `timeout_s`,
/// then SIGKILLs it. Returns its exit code, 128 + the signal that ended it,
/// or -1 when it had to be killed after the timeout.
int StopProcess(pid_t pid, int signal, double timeout_s = 20.0);

/// Calls `done` every 20 ms until it returns true (then true) or `timeout_s`
/// of host time have passed (then false). Tests wait on a condition with a
/// generous deadline, never a fixed sleep followed by "the work is done".
bool WaitUntil(const std::function<bool()>& done, double timeout_s = 60.0);

/// The first line of the file at `path` that starts with `prefix`, once it
/// is there (a process writing it); empty after `timeout_s`.
std::string WaitForLine(const std::string& path, const std::string& prefix, double timeout_s = 20.0);

std::string ReadFile(const std::string& path);
void WriteFile(const std::string& path, const std::string& text);

}  // namespace rocklab::test
