// `rocklab model` and `rocklab compare` as a user starts them: their
// start-up errors (exit 2, a message naming the option and the value), and
// a run over memq:// stopped by SIGINT (exit 0, the end-of-run lines), which
// needs no network namespace. Oracle: the CLI contract of docs/commands.md ("Command
// line": exit code 2, one line naming the option) and each command's
// own end-of-run output.
#include <signal.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/tools/run_cli.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using ::rocklab::test::kLabRig;  // tests/source_paths.h

// True once process `pid` has a handler for `sig` (/proc/PID/status SigCgt):
// the command has installed its stop signals, so a SIGINT stops it in order
// instead of killing it.
bool CatchesSignal(pid_t pid, int sig) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("SigCgt:", 0) != 0) continue;
    const std::uint64_t mask = std::stoull(line.substr(7), nullptr, 16);
    return (mask >> (sig - 1)) & 1u;
  }
  return false;
}

struct Expect {
  std::vector<std::string> args;
  std::vector<std::string> in_err;  // each must appear in stderr
};

void ExpectStartupError(const Expect& e) {
  const test::CliResult r = test::RunCli(e.args);
  std::string cmd;
  for (const std::string& a : e.args) cmd += a + " ";
  EXPECT_EQ(r.exit_code, 2) << cmd << "\n" << r.err;
  for (const std::string& s : e.in_err) EXPECT_NE(r.err.find(s), std::string::npos) << cmd << ": no '" << s << "' in\n" << r.err;
}

TEST(ModelCommand, StartupErrorsNameTheOptionAndExitTwo) {
  const std::string dir = test::ScratchDir("model_cmd");
  for (const Expect& e : std::vector<Expect>{
           {{"model", "--rig", dir + "/no-such-rig.toml", "--variant", "h:housner:theoretical"},
            {"--rig", "no-such-rig.toml"}},
           {{"model", "--rig", kLabRig, "--variant", "h:nope:theoretical"}, {"--variant", "nope"}},
           {{"model", "--rig", kLabRig, "--variant", "h:housner:alpha=0.2,p=-4,mu=0.9"}, {"--variant"}},
           {{"model", "--rig", kLabRig, "--variant", "h:housner:theoretical", "--variant", "h:complex:theoretical"},
            {"--variant", "'h' used twice"}},
           {{"model", "--rig", kLabRig, "--variant", "h:housner:" + dir + "/no-such.json"}, {"--variant", "no-such.json"}},
           {{"model", "--rig", kLabRig, "--lcm-url", "bogus://nowhere"}, {"--lcm-url", "bogus://nowhere"}},
       }) {
    ExpectStartupError(e);
  }
}

TEST(CompareCommand, StartupErrorsNameTheOptionAndExitTwo) {
  for (const Expect& e : std::vector<Expect>{
           {{"compare", "--window", "0"}, {"--window"}},
           {{"compare", "--compare-rate", "-5"}, {"--compare-rate"}},
           {{"compare", "--stale", "nan"}, {"--stale"}},
           {{"compare", "--stale-clock", "moon"}, {"--stale-clock", "moon"}},
           {{"compare", "--lcm-url", "bogus://nowhere"}, {"--lcm-url", "bogus://nowhere"}},
       }) {
    ExpectStartupError(e);
  }
}

// Starts `args`, waits (a condition, 60 s at most) until it catches SIGINT,
// stops it with SIGINT and returns its exit code; stdout and stderr in `out`, `err`.
int RunUntilSigint(const std::vector<std::string>& args, const std::string& name, std::string& out,
                   std::string& err) {
  const std::string dir = test::ScratchDir(name);
  const pid_t pid = test::StartCli(args, dir + "/stdout", dir + "/stderr");
  EXPECT_TRUE(test::WaitUntil([pid] { return CatchesSignal(pid, SIGINT); })) << name << " never caught SIGINT";
  const int code = test::StopProcess(pid, SIGINT);
  out = test::ReadFile(dir + "/stdout");
  err = test::ReadFile(dir + "/stderr");
  return code;
}

TEST(ModelCommand, RunsOverMemqUntilSigint) {
  std::string out, err;
  const int code = RunUntilSigint({"model", "--rig", kLabRig, "--variant", "h:housner:theoretical",
                                   "--lcm-url", "memq://"},
                                  "model_memq", out, err);
  EXPECT_EQ(code, 0) << err;
  EXPECT_NE(err.find("variant h: housner"), std::string::npos) << err;
  EXPECT_NE(err.find("model: 0 table samples"), std::string::npos) << err;
}

TEST(CompareCommand, RunsOverMemqUntilSigintAndPrintsItsSummary) {
  std::string out, err;
  const int code = RunUntilSigint({"compare", "--lcm-url", "memq://"}, "compare_memq", out, err);
  EXPECT_EQ(code, 0) << err;
  EXPECT_EQ(out.rfind("variant", 0), 0u) << out;  // the summary table's header, no variant seen
}

}  // namespace
}  // namespace rocklab::tools
