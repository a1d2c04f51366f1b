// The command-line conventions of docs/commands.md ("Conventions, command
// by command") over every registered command: --help, an unknown option
// with the nearest one named, --json where the table says the command has
// a result (and its output parsed on small inputs), every missing
// required option named in one message, `-` as standard input and
// output, run's provenance, the bash completion made from the command
// table, and the progress line only on a terminal.
//
// Oracle: the table in docs/commands.md and the options each command's
// --help lists; for the JSON, the same command's text or files.
#include <fcntl.h>
#include <sys/stat.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
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
    // A value not of its option's type: the command, option, value and type.
    static const std::regex kNumeric(R"(^\s+(--[a-z][a-z0-9-]*) (FLOAT|INT|UINT)\b)");
    std::istringstream help_lines(help.out);
    for (std::string line; std::getline(help_lines, line);) {
      std::smatch m;
      if (!std::regex_search(line, m, kNumeric)) continue;
      const CliResult nan = RunCli({command, m[1].str(), "abc"});
      EXPECT_EQ(nan.exit_code, 2) << nan.err;
      EXPECT_NE(nan.err.find(command + ": " + m[1].str() + ": 'abc' is not "), std::string::npos) << nan.err;
      break;  // one per command: the conversion is the CLI layer's, not the command's
    }
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
  // A message about standard input's bytes names it <stdin>, never the
  // temporary copy. Oracle: the same bytes from a file named in the message.
  WriteFile(dir + "/bad.csv", "time,theta\n0,0.1\n0.01,abc\n");
  const CliResult bad_file = RunCli({"fit", dir + "/bad.csv", "--width", "0.247", "--height", "1"});
  EXPECT_EQ(bad_file.exit_code, 2);
  const std::string bad_pipe = Shell("cat " + dir + "/bad.csv | " ROCKLAB_BINARY
                                     " fit - --width 0.247 --height 1 2>&1 >/dev/null",
                                     code);
  EXPECT_EQ(code, 2);
  std::string expected = bad_file.err;
  expected.replace(expected.find(dir + "/bad.csv"), (dir + "/bad.csv").size(), "<stdin>");
  EXPECT_EQ(bad_pipe, expected);
  EXPECT_EQ(bad_pipe.find("rocklab-stdin"), std::string::npos) << bad_pipe;
}

// Exit code 1 for a fit whose result is not converged (the work failed;
// its JSON still written), 0 with --allow-unconverged. Oracle: a free
// rocking record whose amplitude is modulated by 2 % at 0.5 Hz (no rocking
// block moves so), with 2e-4 rad of uniform noise: the impacts method's
// chi-square rejects it (p ~ 1e-131 here) at any usual significance.
TEST(CliConventions, UnconvergedFitIsAFailureOfTheWork) {
  const std::string dir = ScratchDir("conventions_unconverged");
  const CliResult sim = RunCli({"simulate", "--alpha", "0.245", "--p", "3.78", "--mu", "0.91", "--theta0", "0.12",
                                "--duration", "6", "--rate", "200", "--out", dir + "/free.csv"});
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  std::istringstream rows(ReadFile(dir + "/free.csv"));
  std::string line, warped = "time,theta\n";
  std::getline(rows, line);  // the header
  std::uint32_t lcg = 12345;
  while (std::getline(rows, line)) {
    double t = 0, theta = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf", &t, &theta), 2) << line;
    lcg = 1103515245u * lcg + 12345u;
    const double noise = 2e-4 * ((lcg >> 1) / 2147483648.0 - 0.5);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f,%.9g\n", t, theta * (1 + 0.02 * std::sin(2 * M_PI * 0.5 * t)) + noise);
    warped += buf;
  }
  WriteFile(dir + "/warped.csv", warped);
  const std::vector<std::string> fit = {"fit", dir + "/warped.csv", "--out", dir + "/fit.json"};
  const CliResult failed = RunCli(fit);
  EXPECT_EQ(failed.exit_code, 1) << failed.err;
  EXPECT_NE(failed.err.find("rocklab fit: the fit has not converged:"), std::string::npos) << failed.err;
  EXPECT_FALSE(nlohmann::json::parse(ReadFile(dir + "/fit.json")).at("converged").get<bool>());
  const CliResult allowed = RunCli(With(fit, {"--allow-unconverged"}));
  EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
  EXPECT_NE(allowed.err.find("warning: the fit has not converged"), std::string::npos) << allowed.err;
  EXPECT_NE(allowed.out.find("NOT converged"), std::string::npos) << allowed.out;
}

// Command -> the options its --help marks REQUIRED (CLI11's help: "NAME
// TYPE REQUIRED"; a positional by its name).
std::map<std::string, std::vector<std::string>> RequiredOptions(const std::vector<std::string>& commands) {
  std::map<std::string, std::vector<std::string>> out;
  static const std::regex kRequired(R"(^\s+(?:-[a-zA-Z],)?(--?[a-z][a-z0-9-]*|[a-z][a-z0-9_-]*)(?:,[^ ]+)?(?: [A-Z:]+)*? REQUIRED)");
  for (const std::string& command : commands) {
    const CliResult help = RunCli({command, "--help"});
    std::istringstream lines(help.out);
    for (std::string line; std::getline(lines, line);) {
      std::smatch m;
      if (std::regex_search(line, m, kRequired)) out[command].push_back(m[1].str());
    }
  }
  return out;
}

// Oracle: each command's --help (the REQUIRED marks); the message must
// name every one, on one line, exit 2.
TEST(CliConventions, EveryMissingRequiredOptionNamedAtOnce) {
  std::vector<std::string> commands;
  for (const auto& [command, options] : CompletionOptions()) commands.push_back(command);
  const auto required = RequiredOptions(commands);
  ASSERT_GE(required.size(), 8u);  // simulate, synth, sweep, report, run, ... have some
  for (const auto& [command, names] : required) {
    SCOPED_TRACE(command);
    const CliResult r = RunCli({command});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const std::string& name : names) {
      std::string shown = name;  // a positional is shown in capitals
      if (shown[0] != '-') std::transform(shown.begin(), shown.end(), shown.begin(), ::toupper);
      EXPECT_NE(r.err.find(shown), std::string::npos) << name << " not named: " << r.err;
    }
  }
  // The issue's case: simulate's four model options and --out in one line;
  // the block's three are required unless an --assembly file is given.
  const CliResult s = RunCli({"simulate", "--theta0", "0.1"});
  EXPECT_EQ(s.exit_code, 2);
  EXPECT_NE(s.err.find("simulate: missing required options --alpha, --p, --mu (or --assembly), --rate, --out;"),
            std::string::npos)
      << s.err;
  const std::string out = ScratchDir("conventions_missing") + "/s.csv";
  const CliResult block = RunCli({"simulate", "--alpha", "0.2", "--rate", "100", "--out", out});
  EXPECT_EQ(block.exit_code, 2);
  EXPECT_NE(block.err.find("simulate: missing required options --p, --mu (or --assembly);"), std::string::npos)
      << block.err;
  EXPECT_EQ(std::count(block.err.begin(), block.err.end(), '\n'), 1) << block.err;
  const CliResult one = RunCli({"simulate", "--alpha", "0.2", "--p", "3", "--mu", "0.9", "--rate", "100"});
  EXPECT_NE(one.err.find("simulate: missing required option --out;"), std::string::npos) << one.err;
}

// Drops the lines (or the footer) that say when and by which command a
// file was made: two runs of one command differ there only.
std::string WithoutProvenance(const std::string& text) {
  std::string out;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# provenance.", 0) == 0 || line.rfind("# rocklab provenance", 0) == 0) continue;
    out += line + "\n";
  }
  const std::size_t foot = out.find("<footer class=\"provenance\"");
  if (foot != std::string::npos) out.erase(foot, out.find("</footer>", foot) + 9 - foot);
  return out;
}

// `-` as standard output for synth, fit (--out, --samples, --plot), sweep
// and report, and as standard input for sweep --records and sweep-plot. Oracle: the same
// command writing a file (byte for byte, but for the provenance lines
// that name the command and the time).
TEST(CliConventions, DashIsStandardOutputWhereTheOutputIsOneStream) {
  const std::string dir = ScratchDir("conventions_stdout");
  const std::string rig = ROCKLAB_SOURCE_DIR "/data/rigs/block1_rig.toml";
  const std::vector<std::string> synth = {"synth", "--rig", rig, "--model", "housner", "--alpha", "0.235", "--p",
                                          "3.884", "--mu", "0.937", "--theta0", "0.1", "--duration", "0.3",
                                          "--rate", "1000", "--truth", dir + "/truth.csv"};
  const CliResult file = RunCli(With(synth, {"--out", dir + "/raw.csv"}));
  ASSERT_EQ(file.exit_code, 0) << file.err;
  const CliResult piped = RunCli(With(synth, {"--out", "-", "--json"}));
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(piped.out, ReadFile(dir + "/raw.csv"));
  EXPECT_NE(piped.err.find("\"samples_written\""), std::string::npos) << "--json to stderr: " << piped.err;
  std::vector<std::string> two_dashes = With(synth, {"--out", "-"});
  *std::find(two_dashes.begin(), two_dashes.end(), dir + "/truth.csv") = "-";
  const CliResult both = RunCli(two_dashes);
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--out - and --truth -"), std::string::npos) << both.err;
  // Any other parse error names the command too.
  const CliResult twice = RunCli(With(synth, {"--out", "-", "--truth", "x.csv"}));
  EXPECT_EQ(twice.exit_code, 2);
  EXPECT_EQ(twice.err.rfind("rocklab: synth: --truth", 0), 0u) << twice.err;

  // fit: free rocking of block 1 from simulate; --out - holds --out FILE's object.
  const CliResult sim = RunCli({"simulate", "--alpha", "0.245", "--p", "3.78", "--mu", "0.91", "--theta0", "0.12",
                                "--duration", "6", "--rate", "200", "--out", dir + "/free.csv"});
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const CliResult fit_file = RunCli({"fit", dir + "/free.csv", "--width", "0.247", "--height", "1",
                                     "--out", dir + "/fit.json"});
  ASSERT_EQ(fit_file.exit_code, 0) << fit_file.err;
  const CliResult fit_pipe = RunCli({"fit", dir + "/free.csv", "--width", "0.247", "--height", "1", "--out", "-"});
  ASSERT_EQ(fit_pipe.exit_code, 0) << fit_pipe.err;
  auto a = nlohmann::json::parse(ReadFile(dir + "/fit.json")), b = nlohmann::json::parse(fit_pipe.out);
  EXPECT_EQ(a.at("provenance").at("sources"), b.at("provenance").at("sources"));  // the record, its size and hash
  EXPECT_EQ(a.at("provenance").at("sources")[0].at("size_bytes").get<long>(),
            static_cast<long>(ReadFile(dir + "/free.csv").size()));
  const nlohmann::json file_source = a.at("provenance").at("sources")[0];
  for (const char* made_when : {"runtime", "provenance"}) {  // the time and command line differ
    a.erase(made_when);
    b.erase(made_when);
  }
  EXPECT_EQ(a, b);
  EXPECT_NE(fit_file.out.find("rocklab fit:"), std::string::npos);
  int piped_code = -1;  // the record from standard input: named <stdin>, with the file's size and hash
  const auto from_stdin = nlohmann::json::parse(
      Shell("cat " + dir + "/free.csv | " ROCKLAB_BINARY " fit - --width 0.247 --height 1 --json", piped_code));
  ASSERT_EQ(piped_code, 0);
  const auto& stdin_source = from_stdin.at("provenance").at("sources")[0];
  EXPECT_EQ(stdin_source.at("path"), "<stdin>");
  EXPECT_EQ(stdin_source.at("sha256"), file_source.at("sha256"));
  EXPECT_EQ(stdin_source.at("size_bytes"), file_source.at("size_bytes"));  // the text summary, not with --out -
  // fit --samples -: the posterior's draws on standard output, the bytes
  // --samples FILE holds (same seed, same draws); the summary and --json
  // on stderr. A short chain: --allow-unconverged.
  const std::vector<std::string> post = {"fit", dir + "/free.csv", "--width", "0.247", "--height", "1",
                                         "--posterior", "--walkers", "12", "--steps", "30", "--threads", "1",
                                         "--allow-unconverged", "--quiet"};
  const CliResult draws_file = RunCli(With(post, {"--samples", dir + "/draws.csv"}));
  ASSERT_EQ(draws_file.exit_code, 0) << draws_file.err;
  const CliResult draws_pipe = RunCli(With(post, {"--samples", "-", "--json"}));
  ASSERT_EQ(draws_pipe.exit_code, 0) << draws_pipe.err;
  EXPECT_EQ(draws_pipe.out, ReadFile(dir + "/draws.csv"));
  EXPECT_EQ(draws_pipe.out.rfind("alpha,p,mu,", 0), 0u) << draws_pipe.out.substr(0, 80);
  EXPECT_NE(draws_pipe.err.find("\"posterior\""), std::string::npos) << "--json to stderr: " << draws_pipe.err;
  const CliResult draws_text = RunCli(With(post, {"--samples", "-"}));
  ASSERT_EQ(draws_text.exit_code, 0) << draws_text.err;
  EXPECT_EQ(draws_text.out, draws_pipe.out);
  EXPECT_NE(draws_text.err.find("rocklab fit:"), std::string::npos) << "the summary to stderr: " << draws_text.err;
  const CliResult corner = RunCli(With(post, {"--plot", "-"}));  // the SVG, its provenance inside
  ASSERT_EQ(corner.exit_code, 0) << corner.err;
  EXPECT_NE(corner.out.find("<svg"), std::string::npos) << corner.out.substr(0, 200);
  EXPECT_NE(corner.out.find("key=\"rocklab_version\""), std::string::npos);
  EXPECT_NE(corner.err.find("rocklab fit:"), std::string::npos) << corner.err;
  const CliResult two_outs = RunCli(With(post, {"--samples", "-", "--out", "-"}));
  EXPECT_EQ(two_outs.exit_code, 2);
  EXPECT_NE(two_outs.err.find("--out - and --samples -"), std::string::npos) << two_outs.err;

  // sweep: the record from standard input, the rows to standard output.
  std::string record = "time,accel\n";
  for (int k = 0; k <= 50; ++k) record += std::to_string(k * 0.02) + "," + (k % 10 < 5 ? "3" : "-3") + "\n";
  ::mkdir((dir + "/in").c_str(), 0755);
  WriteFile(dir + "/in/stdin.csv", record);  // the name a record from - gets
  const std::vector<std::string> sweep = {"sweep", "--alpha", "0.2", "--p", "3", "--scale", "0.5:1.5:3", "--model",
                                          "housner", "--duration", "1.2", "--threads", "1"};
  const CliResult sweep_file = RunCli(With(sweep, {"--records", dir + "/in/stdin.csv", "--out", dir + "/sweep.csv"}));
  ASSERT_EQ(sweep_file.exit_code, 0) << sweep_file.err;
  int code = -1;
  std::string command = "cat " + dir + "/in/stdin.csv | " ROCKLAB_BINARY;
  for (const std::string& arg : sweep) command += " " + arg;
  const std::string rows = Shell(command + " --records - --out - 2>/dev/null", code);
  ASSERT_EQ(code, 0);
  EXPECT_EQ(WithoutProvenance(rows), WithoutProvenance(ReadFile(dir + "/sweep.csv")));
  EXPECT_NE(rows.find("# provenance.command:"), std::string::npos) << rows;
  const CliResult resume = RunCli(With(sweep, {"--records", dir + "/in/stdin.csv", "--out", "-", "--resume"}));
  EXPECT_EQ(resume.exit_code, 2);
  EXPECT_NE(resume.err.find("--out: standard output (-) cannot be written here"), std::string::npos) << resume.err;

  // sweep-plot: the results from standard input.
  const CliResult plot_file = RunCli({"sweep-plot", dir + "/sweep.csv", "--out-dir", dir + "/plot1", "--json"});
  ASSERT_EQ(plot_file.exit_code, 0) << plot_file.err;
  ::mkdir((dir + "/plot2").c_str(), 0755);
  ::mkdir((dir + "/plot1").c_str(), 0755);
  const std::string plot_pipe = Shell("cat " + dir + "/sweep.csv | " ROCKLAB_BINARY " sweep-plot - --out-dir " + dir +
                                          "/plot2 --json",
                                      code);
  ASSERT_EQ(code, 0);
  EXPECT_EQ(nlohmann::json::parse(plot_file.out).at("fragility"), nlohmann::json::parse(plot_pipe).at("fragility"));
}

// run: the provenance of its log (beside it, LOG.provenance.csv) and in
// its summary; the log's readers see the log as before; report --out -.
// Oracle: coreutils' sha256sum of the sources; the report's page written
// to a file.
TEST(CliConventions, RunSaysWhatMadeItsLogAndSummary) {
  const std::string dir = ScratchDir("conventions_run");
  const std::string rig = ROCKLAB_SOURCE_DIR "/data/rigs/block1_rig.toml";
  const CliResult s = RunCli({"synth", "--rig", rig, "--model", "housner", "--alpha", "0.235", "--p", "3.884", "--mu",
                              "0.937", "--theta0", "0.1", "--duration", "0.5", "--rate", "1000", "--out",
                              dir + "/raw.csv", "--truth", dir + "/truth.csv"});
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const CliResult r = RunCli({"run", dir + "/raw.csv", "--rig", rig, "--max", "--variant", "h:housner:theoretical",
                              "--log", dir + "/test.lcm", "--summary", dir + "/summary.json", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  int code = -1;
  auto sha256 = [&code](const std::string& path) { return Shell("sha256sum " + path, code).substr(0, 64); };
  const auto summary = nlohmann::json::parse(ReadFile(dir + "/summary.json"));
  ASSERT_TRUE(summary.contains("provenance")) << summary.dump();
  const auto& p = summary.at("provenance");
  EXPECT_EQ(p.at("rocklab_version").get<std::string>(), RunCli({"--version"}).out.substr(8, p.at("rocklab_version").get<std::string>().size()));
  EXPECT_NE(p.at("command").get<std::string>().find("run "), std::string::npos);
  EXPECT_EQ(p.at("created_utc").get<std::string>().size(), 20u);
  EXPECT_EQ(p.at("rig").at("name"), "lab-table-A-block1");
  ASSERT_EQ(p.at("sources").size(), 2u);
  EXPECT_EQ(p.at("sources")[0].at("sha256"), sha256(rig));
  EXPECT_EQ(p.at("sources")[1].at("sha256"), sha256(dir + "/raw.csv"));
  EXPECT_EQ(p.at("sources")[1].at("size_bytes").get<long>(), static_cast<long>(ReadFile(dir + "/raw.csv").size()));
  const std::string sidecar = ReadFile(dir + "/test.lcm.provenance.csv");
  EXPECT_EQ(sidecar.rfind("key,value\n", 0), 0u) << sidecar;
  EXPECT_NE(sidecar.find(sha256(dir + "/raw.csv")), std::string::npos) << sidecar;
  EXPECT_NE(sidecar.find("\"rig\",\"lab-table-A-block1, calibration 2026-11-01-A\""), std::string::npos) << sidecar;
  // The log as its readers know it: every channel a rocklab type.
  const CliResult info = RunCli({"info", dir + "/test.lcm", "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const nlohmann::json info_json = nlohmann::json::parse(info.out);  // alive through the loop
  for (const auto& channel : info_json.at("channels")) {
    EXPECT_NE(channel.at("type"), "unknown") << channel.dump();
  }
  // report --out -: the page the file gets.
  const CliResult page_file = RunCli({"report", dir + "/test.lcm", "--out", dir + "/r.html", "--quiet"});
  ASSERT_EQ(page_file.exit_code, 0) << page_file.err;
  const CliResult page_pipe = RunCli({"report", dir + "/test.lcm", "--out", "-", "--quiet", "--json"});
  ASSERT_EQ(page_pipe.exit_code, 0) << page_pipe.err;
  EXPECT_EQ(WithoutProvenance(page_pipe.out), WithoutProvenance(ReadFile(dir + "/r.html")));
  EXPECT_NE(page_pipe.out.find("<footer class=\"provenance\""), std::string::npos);
  EXPECT_NE(page_pipe.err.find("\"decode_errors\""), std::string::npos) << "--json to stderr: " << page_pipe.err;
}

// A value out of an option's checked range: the bounds said plainly (CLI11
// printed "not in range 0.000000 to 1797693134862315708...").
TEST(CliConventions, OutOfRangeValueNamesCommandOptionAndBounds) {
  const CliResult r = RunCli({"run", "x.csv", "--rig", "r.toml", "--lookahead", "-1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("run: --lookahead: '-1' is not >= 0;"), std::string::npos) << r.err;
}

// The main input is positional with --input as its alias in every command
// that has one (replay's LOG excepted: its --input is the raw file of
// --rig mode). Oracle: each command's --help (its POSITIONALS section)
// and the completion script's options.
TEST(CliConventions, MainInputPositionalWithInputAlias) {
  const auto commands = CompletionOptions();
  for (const char* command : {"fit", "reconstruct", "daq", "run", "report", "info", "export", "sweep-plot"}) {
    SCOPED_TRACE(command);
    const auto options = commands.find(command);
    ASSERT_NE(options, commands.end());
    EXPECT_TRUE(Has(options->second, "--input"));
    EXPECT_NE(RunCli({command, "--help"}).out.find("Positionals:"), std::string::npos);
  }
  const std::string log_free = ROCKLAB_SOURCE_DIR "/data/samples/fig7_block1.csv";
  const CliResult a = RunCli({"info", log_free, "--json"});
  const CliResult b = RunCli({"info", "--input", log_free, "--json"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  EXPECT_EQ(a.out, b.out);
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
