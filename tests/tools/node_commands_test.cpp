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
#include <nlohmann/json.hpp>

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

// The provenance object of a live node's summary (docs/provenance.md): no
// input file, so no sources; the version as `rocklab --version` says it.
void ExpectLiveProvenance(const nlohmann::json& p, const std::string& command) {
  const std::string version = test::RunCli({"--version"}).out;  // "rocklab VERSION ..."
  ASSERT_TRUE(p.is_object()) << p.dump();
  EXPECT_EQ(version.rfind("rocklab " + p.at("rocklab_version").get<std::string>(), 0), 0u) << version;
  EXPECT_NE(p.at("command").get<std::string>().find(command), std::string::npos) << p.dump();
  EXPECT_EQ(p.at("created_utc").get<std::string>().size(), 20u) << p.dump();  // 2026-11-27T11:40:00Z
  EXPECT_EQ(p.at("sources"), nlohmann::json::array());
}

TEST(CompareCommand, RunsOverMemqUntilSigintAndPrintsItsSummary) {
  std::string out, err;
  const std::string summary = test::ScratchDir("compare_memq_summary") + "/compare.json";
  const int code = RunUntilSigint({"compare", "--lcm-url", "memq://", "--summary", summary}, "compare_memq", out, err);
  EXPECT_EQ(code, 0) << err;
  EXPECT_EQ(out.rfind("variant", 0), 0u) << out;  // the summary table's header, no variant seen
  const auto j = nlohmann::json::parse(test::ReadFile(summary));
  ASSERT_TRUE(j.contains("provenance")) << j.dump();
  ExpectLiveProvenance(j.at("provenance"), "compare --lcm-url memq:// --summary " + summary);
  EXPECT_EQ(j.at("provenance").at("lcm_url"), "memq://");
}

// record: its summary's provenance and the sidecar of its (empty) log,
// written at the stop (record/log_provenance.h). Oracle: the log's size by
// stat (the 0 events of a memq bus no one publishes on).
TEST(RecordCommand, SaysWhatMadeItsLogAndSummary) {
  const std::string dir = test::ScratchDir("record_memq_provenance");
  std::string out, err;
  const int code = RunUntilSigint({"record", dir + "/rec.lcm", "--channels", "RL_.*", "--summary",
                                   dir + "/rec.json", "--force", "--lcm-url", "memq://"},
                                  "record_memq", out, err);
  EXPECT_EQ(code, 0) << err;
  const auto j = nlohmann::json::parse(test::ReadFile(dir + "/rec.json"));
  ASSERT_TRUE(j.contains("provenance")) << j.dump();
  ExpectLiveProvenance(j.at("provenance"), "record " + dir + "/rec.lcm --channels 'RL_.*'");
  EXPECT_EQ(j.at("provenance").at("channels"), "RL_.*");
  const std::string sidecar = test::ReadFile(dir + "/rec.lcm.provenance.csv");
  EXPECT_EQ(sidecar.rfind("key,value\n", 0), 0u) << sidecar;
  EXPECT_NE(sidecar.find("\"channels\",\"RL_.*\"\n"), std::string::npos) << sidecar;
  EXPECT_NE(sidecar.find("\"events\",\"0\"\n"), std::string::npos) << sidecar;
  EXPECT_NE(sidecar.find("\"bytes\",\"" + std::to_string(std::ifstream(dir + "/rec.lcm", std::ios::ate).tellg()) +
                         "\"\n"),
            std::string::npos)
      << sidecar;
  EXPECT_NE(sidecar.find("\"log_series\",\"" + dir + "/rec.lcm\"\n"), std::string::npos) << sidecar;
}

}  // namespace
}  // namespace rocklab::tools
