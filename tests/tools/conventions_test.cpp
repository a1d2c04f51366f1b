// The command-line conventions of docs/commands.md ("Conventions, command
// by command") over every registered command: --help, an unknown option
// with the nearest one named, --json where the table says the command has
// a result (and its output parsed on small inputs), `-` as standard input,
// the bash completion made from the command table, and the progress line
// only on a terminal.
//
// Oracle: the table in docs/commands.md and the options each command's
// --help lists; for the JSON, the same command's text or files.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

// Command -> its long options, from `rocklab completion bash` (the command
// table as the binary registers it).
std::map<std::string, std::vector<std::string>> CompletionOptions() {
  const CliResult r = RunCli({"completion", "bash"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::map<std::string, std::vector<std::string>> out;
  static const std::regex kCase(R"(^    ([a-z][a-z-]*)\) options='([^']*)' ;;$)");
  std::istringstream lines(r.out);
  std::string line;
  while (std::getline(lines, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, kCase)) continue;
    std::istringstream words(m[2].str());
    std::vector<std::string>& options = out[m[1].str()];
    for (std::string w; words >> w;) options.push_back(w);
  }
  return out;
}

// Command -> the table's result cell, from docs/commands.md.
std::map<std::string, std::string> DocumentedResults() {
  std::ifstream in(ROCKLAB_SOURCE_DIR "/docs/commands.md");
  std::map<std::string, std::string> out;
  static const std::regex kRow(R"(^\| `([a-z-]+)` \| ([^|]+) \|)");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, kRow)) out[m[1].str()] = m[2].str();
  }
  return out;
}

bool Has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(CliConventions, EveryCommandHelpsRefusesUnknownOptionsAndHasJsonWhereDocumented) {
  const auto commands = CompletionOptions();
  const auto documented = DocumentedResults();
  ASSERT_GE(commands.size(), 20u);
  for (const auto& [command, options] : commands) {
    SCOPED_TRACE(command);
    const CliResult help = RunCli({command, "--help"});
    EXPECT_EQ(help.exit_code, 0) << help.err;
    for (const std::string& option : options) {
      EXPECT_NE(help.out.find(option), std::string::npos) << option << " not in --help";
    }
    // A typo of one of its options, two neighbours swapped: named, with it.
    std::string option, typo;
    for (const std::string& o : options) {
      if (o.size() < 6 || o[2] == o[3]) continue;
      option = typo = o;
      std::swap(typo[2], typo[3]);
      if (!Has(options, typo)) break;
    }
    ASSERT_FALSE(option.empty());
    const CliResult bad = RunCli({command, typo});
    EXPECT_EQ(bad.exit_code, 2) << bad.err;
    EXPECT_NE(bad.err.find("unknown option " + typo), std::string::npos) << bad.err;
    EXPECT_NE(bad.err.find("did you mean " + option + "?"), std::string::npos) << bad.err;
    const auto row = documented.find(command);
    ASSERT_NE(row, documented.end()) << "not in docs/commands.md's conventions table";
    const bool has_result = row->second.rfind("yes", 0) == 0;
    EXPECT_EQ(Has(options, "--json"), has_result) << "the table says: " << row->second;
  }
}

std::vector<std::string> With(std::vector<std::string> args, const std::vector<std::string>& more) {
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

// --json on small bundled or made inputs: one object on stdout, whose
// figures are those of the text or files the command also writes.
TEST(CliConventions, JsonOutputsParse) {
  const std::string dir = ScratchDir("conventions_json");
  const std::string rig = ROCKLAB_SOURCE_DIR "/data/rigs/block1_rig.toml";
  const std::vector<std::string> synth = {"synth", "--rig", rig, "--model", "housner", "--alpha", "0.235", "--p",
                                          "3.884", "--mu", "0.937", "--theta0", "0.1", "--duration", "0.5",
                                          "--rate", "1000", "--out", dir + "/raw.csv", "--truth",
                                          dir + "/truth.csv"};
  const CliResult s = RunCli(With(synth, {"--json"}));
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const auto sj = nlohmann::json::parse(s.out);
  EXPECT_EQ(sj.at("samples_written").get<long>() + sj.at("samples_dropped").get<long>(), 501);

  const CliResult r = RunCli({"reconstruct", dir + "/raw.csv", "--rig", rig, "--out", dir + "/theta.csv", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rj = nlohmann::json::parse(r.out);
  const std::string theta = ReadFile(dir + "/theta.csv");
  EXPECT_EQ(rj.at("rows_written").get<long>(), std::count(theta.begin(), theta.end(), '\n') - 1);

  const CliResult e = RunCli({"export", dir + "/raw.csv", "--out", dir + "/export.csv", "--rate", "1000", "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto ej = nlohmann::json::parse(e.out);
  EXPECT_EQ(ej.at("rows").get<long>(), sj.at("samples_written").get<long>());

  const CliResult d = RunCli({"demo", "--out-dir", dir + "/demo", "--json"});
  ASSERT_EQ(d.exit_code, 0) << d.err;
  const auto dj = nlohmann::json::parse(d.out);
  ASSERT_EQ(dj.at("models").size(), 2u);
  const CliResult dt = RunCli({"demo", "--out-dir", dir + "/demo"});
  EXPECT_NE(dt.out.find(" " + std::to_string(dj.at("models")[0].at("impacts").get<int>()) + " "), std::string::npos);

  // --out - with --json: the CSV on stdout, the JSON on stderr.
  const CliResult both = RunCli({"reconstruct", dir + "/raw.csv", "--rig", rig, "--out", "-", "--json"});
  ASSERT_EQ(both.exit_code, 0) << both.err;
  EXPECT_EQ(both.out, theta);
  EXPECT_NE(both.err.find("\"rows_written\""), std::string::npos) << both.err;
}

// Runs `command` in sh (stdin from `input`), returning stdout; `code`
// gets the exit code.
std::string Shell(const std::string& command, int& code) {
  FILE* p = ::popen(command.c_str(), "r");
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = ::pclose(p);
  code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

// Oracle: the same command on the file.
TEST(CliConventions, DashIsStandardInputForCsvAndRefusedForLogs) {
  const std::string dir = ScratchDir("conventions_stdin");
  WriteFile(dir + "/section.csv", "x,z\n0,0\n0.4,0\n0.2,1\n0,1\n");
  const CliResult file = RunCli({"params", "--polygon", dir + "/section.csv", "--json"});
  ASSERT_EQ(file.exit_code, 0) << file.err;
  int code = -1;
  const std::string piped =
      Shell("cat " + dir + "/section.csv | " ROCKLAB_BINARY " params --polygon - --json", code);
  ASSERT_EQ(code, 0);
  auto a = nlohmann::json::parse(file.out), b = nlohmann::json::parse(piped);
  a.erase("polygon");
  b.erase("polygon");
  EXPECT_EQ(a, b);
  const CliResult log = RunCli({"report", "-", "--out", dir + "/r.html"});
  EXPECT_EQ(log.exit_code, 2);
  EXPECT_NE(log.err.find("standard input (-) cannot be read here"), std::string::npos) << log.err;
}

// Oracle: bash's own completion machinery on the generated script.
TEST(CliConventions, BashCompletionFromTheCommandTable) {
  const std::string dir = ScratchDir("conventions_completion");
  const CliResult script = RunCli({"completion", "bash"});
  ASSERT_EQ(script.exit_code, 0);
  WriteFile(dir + "/rocklab.bash", script.out);
  WriteFile(dir + "/probe.sh",
            "source " + dir + "/rocklab.bash\n"
            "COMP_WORDS=(rocklab sim); COMP_CWORD=1; _rocklab; echo \"${COMPREPLY[*]}\"\n"
            "COMP_WORDS=(rocklab simulate --al); COMP_CWORD=2; _rocklab; echo \"${COMPREPLY[*]}\"\n"
            "COMP_WORDS=(rocklab help sweep); COMP_CWORD=2; _rocklab; echo \"${COMPREPLY[*]}\"\n");
  int code = -1;
  const std::string out = Shell("bash " + dir + "/probe.sh", code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_EQ(out, "simulate\n--alpha\nsweep sweep-plot\n");
}

// What `args` writes on stderr when stderr is a terminal (a pty), read
// until the command exits.
std::string StderrOnATerminal(const std::vector<std::string>& args) {
  int master = -1, slave = -1;
  if (::openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) return "";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(slave, 2);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    std::vector<char*> argv{const_cast<char*>(ROCKLAB_BINARY)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(ROCKLAB_BINARY, argv.data());
    ::_exit(127);
  }
  ::close(slave);
  std::string out;
  char buf[4096];
  for (;;) {
    pollfd p{master, POLLIN, 0};
    if (::poll(&p, 1, 20000) <= 0) break;
    const ssize_t n = ::read(master, buf, sizeof buf);
    if (n <= 0) break;  // EIO once the child has closed the pty
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(master);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return out;
}

// Oracle: the line format of common/progress.h; a pipe gets none of it.
TEST(CliConventions, ProgressOnlyOnATerminal) {
  const std::string dir = ScratchDir("conventions_progress");
  std::string record = "time,accel\n";
  for (int k = 0; k <= 100; ++k) record += std::to_string(k * 0.01) + "," + (k % 20 < 10 ? "3" : "-3") + "\n";
  WriteFile(dir + "/rec.csv", record);
  const std::vector<std::string> sweep = {"sweep", "--records", dir + "/rec.csv", "--alpha", "0.2", "--p", "3",
                                          "--scale", "0.5:1.5:4", "--model", "housner", "--duration", "1.5",
                                          "--threads", "1", "--out", dir + "/out.csv"};
  const std::string tty = StderrOnATerminal(sweep);
  EXPECT_NE(tty.find("sweep    ["), std::string::npos) << tty;
  EXPECT_NE(tty.find("/4 rows"), std::string::npos) << tty;
  EXPECT_NE(tty.find("\r\033[K"), std::string::npos) << "the line is cleared at the end: " << tty;
  const CliResult piped = RunCli(sweep);
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(piped.err.find('\r'), std::string::npos) << piped.err;
}

}  // namespace
}  // namespace rocklab::test
