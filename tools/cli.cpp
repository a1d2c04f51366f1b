#include "tools/cli.h"

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <regex>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "common/bus_urls.h"
#include "common/atomic_file.h"
#include "common/text.h"
#include "compare/compare_node.h"
#include "model/model_node.h"
#include "pipeline/pipeline.h"

namespace rocklab::tools {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int) { g_stop.store(true); }
}  // namespace

std::string SubscriberUrl(const std::string& url) {
  const std::string out = common::ResolveLcmUrl(url);
  if (out.rfind("udpm://", 0) != 0 || out.find("recv_buf_size=") != std::string::npos) return out;
  return out + (out.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=4194304";
}

CLI::Option* AddRawUrlOption(CLI::App& cmd, std::string& raw_url) {
  return cmd.add_option("--raw-url", raw_url,
                        "LCM URL of RL_RAW (default: --lcm-url's udpm group and port + 1, else the same bus; "
                        "'same': the main bus)");
}

const std::atomic<bool>& InstallStopSignals() {
  static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  return g_stop;
}

std::size_t EditDistance(std::string_view a, std::string_view b) {
  // Optimal string alignment: insertions, deletions, substitutions and
  // swaps of two neighbours (`--otu` for `--out`) each cost one edit.
  const std::size_t w = b.size() + 1;
  std::vector<std::size_t> d((a.size() + 1) * w);
  for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    d[i * w] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      std::size_t best = std::min({d[(i - 1) * w + j] + 1, d[i * w + j - 1] + 1,
                                   d[(i - 1) * w + j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        best = std::min(best, d[(i - 2) * w + j - 2] + 1);
      }
      d[i * w + j] = best;
    }
  }
  return d[a.size() * w + b.size()];
}

std::string DidYouMean(std::string_view word, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_distance = 0;
  for (const std::string& name : names) {
    const std::size_t d = EditDistance(word, name);
    const std::size_t limit = std::min<std::size_t>(2, std::max(word.size(), name.size()) / 3);
    if (d <= limit && (best.empty() || d < best_distance)) {
      best = name;
      best_distance = d;
    }
  }
  if (!best.empty() || word.empty()) return best;
  std::string prefix_of;
  for (const std::string& name : names) {
    if (name.compare(0, word.size(), word) != 0) continue;
    if (!prefix_of.empty()) return "";  // the start of two names: no guess
    prefix_of = name;
  }
  return prefix_of;
}

std::string UnknownOption(const CLI::App& cmd, const std::vector<std::string>& args) {
  std::vector<std::string> names;  // with their dashes
  auto known = [&cmd](const std::string& name) {
    return cmd.get_option_no_throw(name) != nullptr;
  };
  for (const CLI::Option* opt : cmd.get_options()) {
    for (const std::string& l : opt->get_lnames()) names.push_back("--" + l);
    for (const std::string& s : opt->get_snames()) names.push_back("-" + s);
  }
  for (const std::string& arg : args) {
    if (arg == "--") break;
    std::string name;
    if (arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      name = arg.substr(0, arg.find('='));
    } else if (arg.size() == 2 && arg[0] == '-' && std::isalpha(static_cast<unsigned char>(arg[1]))) {
      name = arg;
    } else {
      continue;
    }
    if (known(name)) continue;
    std::string message = cmd.get_name() + ": unknown option " + name;
    const std::string near = DidYouMean(name, names);
    message += near.empty() ? "" : " (did you mean " + near + "?)";
    return message + "; `rocklab help " + cmd.get_name() + "` lists its options";
  }
  return "";
}

CLI::Option* AddJsonFlag(CLI::App& cmd, bool& json) {
  return cmd.add_flag("--json", json, "print the result as JSON on standard output (docs/commands.md)");
}

void WriteResult(const nlohmann::json& result, bool json, const std::string& summary_path, bool stdout_taken,
                 const char* summary_option) {
  const std::string text = result.dump(2) + "\n";
  if (summary_path == "-") {
    std::fputs(text.c_str(), stdout);
  } else if (!summary_path.empty()) {
    try {
      common::WriteFileAtomically(summary_path, text);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(std::string(summary_option) + ": " + e.what());
    }
  }
  if (json && summary_path != "-") std::fputs(text.c_str(), stdout_taken ? stderr : stdout);
  std::fflush(stdout);
}

void PrintStackAssumptions(const model::ModelNode& node, const char* what) {
  if (node.impacts_preload() > 0 || node.impacts_held_pivots() > 0) {
    // The stack model's assumptions (docs/models.md): each RL_EVENT's detail names its rule.
    std::fprintf(stderr, "%s: %lld assembly impacts resolved within the preloads, %lld with pivots held\n", what,
                 static_cast<long long>(node.impacts_preload()), static_cast<long long>(node.impacts_held_pivots()));
  }
  if (node.start_refusals() > 0) {
    std::fprintf(stderr, "%s: %lld measured starts of a stack (RL_BODIES) refused: those stacks started at rest\n",
                 what, static_cast<long long>(node.start_refusals()));
  }
}

void WriteCompareResult(const compare::CompareNode& node, bool json, const std::string& summary_path,
                        const nlohmann::json* extra) {
  const auto summary = node.Summary();
  const auto bands = node.BandSummaries();
  if (!json && summary_path != "-") {
    compare::CompareNode::PrintSummary(summary, stdout);
    compare::CompareNode::PrintBandSummary(bands, stdout);
  }
  nlohmann::json result = nlohmann::json::parse(compare::CompareNode::SummaryJsonText(summary, bands));
  if (extra != nullptr) result.update(*extra);
  WriteResult(result, json, summary_path);
}

int RunDaqStageCommand(pipeline::DaqStageOptions& options, const char* what, bool json) {
  daq::DaqNodeStats s;
  if (json) options.stats_out = &s;
  const int code = pipeline::RunDaqStage(options, what, InstallStopSignals());
  if (json) {
    WriteResult({{"input", options.input},
                 {"frames_read", s.frames_read},
                 {"published", s.published},
                 {"publish_errors", s.publish_errors},
                 {"gaps", s.gaps},
                 {"samples_missing", s.missing},
                 {"bad_samples", s.bad_samples},
                 {"problems", s.problems},
                 {"damaged_regions", s.damaged_regions},
                 {"damaged_bytes", s.damaged_bytes},
                 {"damaged_events", s.damaged_events},
                 {"restarts", s.restarts},
                 {"restart_samples_lost", s.restart_lost},
                 {"comments", s.comments},
                 {"stopped_early", s.stopped_early},
                 {"read_error", s.read_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.read_error)}},
                true);
  }
  return code;
}

namespace {
// A temporary made for standard input or output: removed at exit, with
// the folder it sits in when it has one of its own.
struct CliTemporary {
  std::string path;
  std::string folder;  // "" when none
  CliTemporary() = default;
  CliTemporary(const CliTemporary&) = delete;
  CliTemporary& operator=(const CliTemporary&) = delete;
  ~CliTemporary() { Remove(); }
  void Remove() {
    if (!path.empty()) ::unlink(path.c_str());
    if (!folder.empty()) ::rmdir(folder.c_str());
    path.clear();
    folder.clear();
  }
};
CliTemporary g_stdin_copy;

std::string TemporaryFolder() {
  const char* tmp = std::getenv("TMPDIR");
  return tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
}

// Reads what `fd` yields into `buf`; -1 on an error (errno says which).
ssize_t ReadSome(int fd, char* buf, std::size_t size) {
  for (;;) {
    const ssize_t n = ::read(fd, buf, size);
    if (n >= 0 || errno != EINTR) return n;
  }
}

bool WriteAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}
}  // namespace

std::string InputFile(const std::string& option, const std::string& path, const char* suffix,
                      const char* hdf5_suffix) {
  if (path != "-") return path;
  if (!g_stdin_copy.path.empty()) {
    throw UsageError(option + ": standard input (-) is already the input of another option");
  }
  // The first bytes say the format where the reader is told it by the name.
  std::vector<char> buf(1 << 16);
  std::size_t head = 0;
  while (head < 8) {
    const ssize_t n = ReadSome(STDIN_FILENO, buf.data() + head, buf.size() - head);
    if (n < 0) throw std::runtime_error(option + ": cannot read standard input: " + std::strerror(errno));
    if (n == 0) break;
    head += static_cast<std::size_t>(n);
  }
  static const char kHdf5Signature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  if (hdf5_suffix != nullptr && head >= 8 && std::memcmp(buf.data(), kHdf5Signature, 8) == 0) suffix = hdf5_suffix;
  std::string folder = TemporaryFolder() + "/rocklab-stdin-XXXXXX";
  if (::mkdtemp(folder.data()) == nullptr) {
    throw std::runtime_error(option + ": cannot make a temporary folder for standard input: " + std::strerror(errno));
  }
  g_stdin_copy.folder = folder;
  const std::string name = folder + "/stdin" + suffix;
  const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(option + ": cannot make " + name + " for standard input: " + std::strerror(errno));
  g_stdin_copy.path = name;
  for (std::size_t n = head;;) {
    if (!WriteAll(fd, buf.data(), n)) {
      const int error = errno;
      ::close(fd);
      throw std::runtime_error(option + ": cannot copy standard input to " + name + ": " + std::strerror(error));
    }
    const ssize_t got = ReadSome(STDIN_FILENO, buf.data(), buf.size());
    if (got < 0) {
      const int error = errno;
      ::close(fd);
      throw std::runtime_error(option + ": cannot read standard input: " + std::strerror(error));
    }
    if (got == 0) break;
    n = static_cast<std::size_t>(got);
  }
  if (::close(fd) != 0) throw std::runtime_error(option + ": cannot copy standard input to " + name + ": " + std::strerror(errno));
  common::ShowPathAs(name, "<stdin>");  // messages and log lines name what was given
  return name;
}

OutputTarget::OutputTarget(std::string option, std::string path, const char* suffix)
    : option_(std::move(option)), given_(std::move(path)), write_path_(given_) {
  if (given_ != "-") return;
  std::string name = TemporaryFolder() + "/rocklab-stdout-XXXXXX" + suffix;
  const int fd = ::mkstemps(name.data(), static_cast<int>(std::strlen(suffix)));
  if (fd < 0) {
    throw std::runtime_error(option_ + ": cannot make a temporary file for standard output: " + std::strerror(errno));
  }
  ::close(fd);
  temp_ = write_path_ = name;
}

OutputTarget::~OutputTarget() {
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void OutputTarget::Finish() {
  if (temp_.empty()) return;
  std::fflush(stdout);  // what the command printed before comes first
  const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(option_ + " -: cannot read back " + temp_ + ": " + std::strerror(errno));
  std::vector<char> buf(1 << 16);
  for (;;) {
    const ssize_t n = ReadSome(fd, buf.data(), buf.size());
    if (n == 0) break;
    if (n < 0 || !WriteAll(STDOUT_FILENO, buf.data(), static_cast<std::size_t>(n))) {
      const int error = errno;
      ::close(fd);
      throw std::runtime_error(option_ + " -: cannot write to standard output: " + std::strerror(error));
    }
  }
  ::close(fd);
}

void RefuseStandardOutput(const std::string& option, const std::string& path, const char* what) {
  if (path == "-") {
    throw UsageError(option + ": standard output (-) cannot be written here: " + what + " (give a file)");
  }
}

namespace {

// RequiredUnless's pairs: option, its alternative (the commands' options
// live as long as the program's CLI::App).
std::vector<std::pair<const CLI::Option*, const CLI::Option*>>& ConditionalRequired() {
  static std::vector<std::pair<const CLI::Option*, const CLI::Option*>> pairs;
  return pairs;
}

// The conditional options of `cmd` missing with their alternative, one
// entry per alternative: "--alpha, --p, --mu (or --assembly)"; `count`
// grows by the options named.
std::vector<std::string> MissingConditional(const CLI::App& cmd, std::size_t& count) {
  std::vector<std::pair<const CLI::Option*, std::string>> groups;  // alternative, names
  const std::vector<const CLI::Option*> own = cmd.get_options();
  for (const auto& pair : ConditionalRequired()) {
    const CLI::Option* option = pair.first;
    const CLI::Option* alternative = pair.second;  // a plain variable: lambdas cannot capture bindings in C++17
    if (std::find(own.begin(), own.end(), option) == own.end()) continue;
    if (option->count() > 0 || alternative->count() > 0) continue;
    auto group = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == alternative; });
    if (group == groups.end()) group = groups.insert(groups.end(), {alternative, std::string()});
    group->second += (group->second.empty() ? "--" : ", --") + option->get_lnames().front();
    ++count;
  }
  std::vector<std::string> missing;
  for (const auto& [alternative, names] : groups) {
    missing.push_back(names + " (or --" + alternative->get_lnames().front() + ")");
  }
  return missing;
}

// "simulate: missing required options A, B; ..." (`count` options named).
std::string MissingMessage(const CLI::App* cmd, bool top, const std::vector<std::string>& missing,
                           std::size_t count) {
  std::string list;
  for (std::size_t i = 0; i < missing.size(); ++i) list += (i == 0 ? "" : ", ") + missing[i];
  const std::string where = top ? "" : cmd->get_name() + ": ";
  return where + "missing required " + (count == 1 ? "option " : "options ") + list + "; `rocklab help " +
         (top ? std::string() : cmd->get_name()) + "` lists its options";
}

}  // namespace

void RequiredUnless(CLI::Option* option, const CLI::Option* alternative) {
  ConditionalRequired().emplace_back(option, alternative);
}

void CheckRequiredUnless(const CLI::App& cmd) {
  std::size_t count = 0;
  const std::vector<std::string> missing = MissingConditional(cmd, count);
  if (!missing.empty()) throw UsageError(MissingMessage(&cmd, cmd.get_parent() == nullptr, missing, count));
}

std::string MissingRequired(const CLI::App& app) {
  const CLI::App* cmd = &app;
  for (const CLI::App* sub : app.get_subcommands()) cmd = sub;  // the one parsed
  std::size_t count = 0;
  std::vector<std::string> missing = MissingConditional(*cmd, count);
  const std::size_t conditional_entries = missing.size();
  for (const CLI::Option* opt : cmd->get_options()) {
    if (!opt->get_required() || opt->count() > 0) continue;
    const std::string positional = opt->get_name(true);
    const std::vector<std::string>& longs = opt->get_lnames();
    std::string name = longs.empty() ? opt->get_name() : "--" + longs.front();
    if (!opt->get_positional() || positional.empty() || positional[0] == '-') {
      missing.push_back(name);
    } else {
      std::string upper = positional;
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      missing.push_back(upper + (longs.empty() ? "" : " (or " + name + ")"));
    }
  }
  if (missing.empty()) return "";
  return MissingMessage(cmd, cmd == &app, missing, count + missing.size() - conditional_entries);
}

void RefuseStandardInput(const std::string& option, const std::string& path, const char* what) {
  if (path == "-") {
    throw UsageError(option + ": standard input (-) cannot be read here: " + what + " (give the file)");
  }
}

void RequireOneStandardOutput(const std::vector<std::pair<std::string, std::string>>& outputs) {
  std::string first;
  for (const auto& [option, path] : outputs) {
    if (path != "-") continue;
    if (!first.empty()) {
      throw UsageError(first + " - and " + option + " -: only one of them can be standard output");
    }
    first = option;
  }
}

void RequireOutputFolder(const std::string& option, const std::string& file) {
  if (file.empty() || file == "-") return;
  std::filesystem::path folder = std::filesystem::path(file).parent_path();
  if (folder.empty()) folder = ".";
  if (!std::filesystem::is_directory(folder)) {
    throw UsageError(option + ": folder '" + folder.string() + "' does not exist (for '" + file + "')");
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    throw UsageError(option + ": folder '" + folder.string() + "' is not writable (for '" + file + "')");
  }
}

namespace {
// "a number", "an integer", ... for CLI11's type name (a check's name after a colon).
std::string ExpectedType(const CLI::Option* opt) {
  std::string type = opt != nullptr ? opt->get_type_name() : "";
  type = type.substr(0, type.find(':'));
  if (type == "FLOAT") return "a number";
  if (type == "INT") return "an integer";
  if (type == "UINT") return "a whole number >= 0";
  if (!type.empty()) return "of type " + type;
  return "a value of the option's type";
}

const CLI::App* ParsedCommand(const CLI::App& app) {
  const CLI::App* cmd = &app;
  for (const CLI::App* sub : app.get_subcommands()) cmd = sub;  // the one parsed
  return cmd;
}

std::string HelpHint(const CLI::App& app, const CLI::App* cmd) {
  return "; `rocklab help " + (cmd == &app ? std::string() : cmd->get_name()) + "` says what it takes";
}

// Whether `text` reads whole as a number of the option's type.
bool ReadsAsNumber(const std::string& text, bool integer) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  if (integer) {
    (void)std::strtoll(text.c_str(), &end, 0);
  } else {
    (void)std::strtod(text.c_str(), &end);
  }
  return errno == 0 && end != nullptr && *end == '\0';
}
}  // namespace

std::string ValidationMessage(const CLI::App& app, const std::string& what) {
  const CLI::App* cmd = ParsedCommand(app);
  const std::string where = cmd == &app ? "" : cmd->get_name() + ": ";
  const std::size_t colon = what.find(": ");
  const CLI::Option* opt = colon == std::string::npos ? nullptr : cmd->get_option_no_throw(what.substr(0, colon));
  if (opt == nullptr) return ParseErrorMessage(app, what);
  const std::string name = what.substr(0, colon);
  const std::string type = ExpectedType(opt);
  if (type == "a number" || type == "an integer" || type == "a whole number >= 0") {
    for (const std::string& value : opt->results()) {
      if (!ReadsAsNumber(value, type != "a number")) {
        return where + name + ": " + common::Quote(value) + " is not " + type + HelpHint(app, cmd);
      }
    }
  }
  static const std::regex kRange(R"(Value (.*) not in range (\S+) to (\S+))");
  std::smatch m;
  if (std::regex_search(what, m, kRange)) {
    const double low = std::strtod(m[2].str().c_str(), nullptr), high = std::strtod(m[3].str().c_str(), nullptr);
    char bounds[96];
    if (high > 1e300) {
      std::snprintf(bounds, sizeof bounds, ">= %g", low);
    } else {
      std::snprintf(bounds, sizeof bounds, "in [%g, %g]", low, high);
    }
    return where + name + ": " + common::Quote(m[1].str()) + " is not " + bounds + HelpHint(app, cmd);
  }
  return ParseErrorMessage(app, what);
}

std::string ParseErrorMessage(const CLI::App& app, const std::string& what) {
  const CLI::App* cmd = ParsedCommand(app);
  const std::string where = cmd == &app ? "" : cmd->get_name() + ": ";
  return what.compare(0, where.size(), where) == 0 ? what : where + what;
}

std::string ConversionMessage(const CLI::App& app, const std::string& what) {
  static const std::string kPrefix = "Could not convert: ";
  if (what.compare(0, kPrefix.size(), kPrefix) != 0) return what;
  const std::size_t eq = what.find(" = ", kPrefix.size());
  if (eq == std::string::npos) return what;
  const std::string name = what.substr(kPrefix.size(), eq - kPrefix.size());
  const std::string value = what.substr(eq + 3);
  const CLI::App* cmd = ParsedCommand(app);
  const std::string where = cmd == &app ? "" : cmd->get_name() + ": ";
  return where + name + ": " + common::Quote(value) + " is not " + ExpectedType(cmd->get_option_no_throw(name)) +
         HelpHint(app, cmd);
}

std::string BashCompletion(const CLI::App& app) {
  std::string commands;
  std::string cases;
  for (const CLI::App* sub : app.get_subcommands({})) {
    commands += (commands.empty() ? "" : " ") + sub->get_name();
    std::string options;
    for (const CLI::Option* opt : sub->get_options()) {
      for (const std::string& l : opt->get_lnames()) options += (options.empty() ? "--" : " --") + l;
    }
    cases += "    " + sub->get_name() + ") options='" + options + "' ;;\n";
  }
  return "# bash completion for rocklab; generated by `rocklab completion bash` from its command table\n"
         "_rocklab() {\n"
         "  local cur=${COMP_WORDS[COMP_CWORD]} commands='" + commands + "' options=''\n"
         "  if [[ $COMP_CWORD -eq 1 ]]; then\n"
         "    COMPREPLY=($(compgen -W \"$commands help completion --version\" -- \"$cur\"))\n"
         "    return\n"
         "  fi\n"
         "  case ${COMP_WORDS[1]} in\n"
         "    help) [[ $COMP_CWORD -eq 2 ]] && COMPREPLY=($(compgen -W \"$commands\" -- \"$cur\")); return ;;\n"
         "    completion) [[ $COMP_CWORD -eq 2 ]] && COMPREPLY=($(compgen -W bash -- \"$cur\")); return ;;\n" +
         cases +
         "  esac\n"
         "  if [[ $cur == -* ]]; then\n"
         "    COMPREPLY=($(compgen -W \"$options --help\" -- \"$cur\"))\n"
         "  else\n"
         "    COMPREPLY=($(compgen -f -- \"$cur\"))\n"
         "  fi\n"
         "}\n"
         "complete -o filenames -o bashdefault -F _rocklab rocklab\n";
}

std::string CommandList(const CLI::App& app) {
  std::string out = app.get_description() + "\n\nusage: rocklab COMMAND [OPTIONS]\n\ncommands:\n";
  std::size_t width = 0;
  for (const CLI::App* sub : app.get_subcommands({})) width = std::max(width, sub->get_name().size());
  for (const CLI::App* sub : app.get_subcommands({})) {
    out += "  " + sub->get_name() + std::string(width + 2 - sub->get_name().size(), ' ') +
           sub->get_description() + "\n";
  }
  out += "\nrocklab help COMMAND (or rocklab COMMAND --help): the command's options\n"
         "rocklab completion bash: a bash completion script (installed as share/bash-completion/completions/rocklab)\n"
         "rocklab --version: the version; docs/commands.md: every command in full\n";
  return out;
}

}  // namespace rocklab::tools
