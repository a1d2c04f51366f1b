#include "tools/cli.h"

#include <algorithm>
#include <cctype>
#include <csignal>
#include <filesystem>

#include <unistd.h>

#include "common/bus_urls.h"
#include "common/text.h"

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

void RequireOutputFolder(const std::string& option, const std::string& file) {
  if (file.empty()) return;
  std::filesystem::path folder = std::filesystem::path(file).parent_path();
  if (folder.empty()) folder = ".";
  if (!std::filesystem::is_directory(folder)) {
    throw UsageError(option + ": folder '" + folder.string() + "' does not exist (for '" + file + "')");
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    throw UsageError(option + ": folder '" + folder.string() + "' is not writable (for '" + file + "')");
  }
}

std::string ConversionMessage(const CLI::App& app, const std::string& what) {
  static const std::string kPrefix = "Could not convert: ";
  if (what.compare(0, kPrefix.size(), kPrefix) != 0) return what;
  const std::size_t eq = what.find(" = ", kPrefix.size());
  if (eq == std::string::npos) return what;
  const std::string name = what.substr(kPrefix.size(), eq - kPrefix.size());
  const std::string value = what.substr(eq + 3);
  const CLI::App* cmd = &app;
  for (const CLI::App* sub : app.get_subcommands()) cmd = sub;  // the one parsed
  const CLI::Option* opt = cmd->get_option_no_throw(name);
  std::string type = opt != nullptr ? opt->get_type_name() : "";
  if (type == "FLOAT") {
    type = "a number";
  } else if (type == "INT" || type == "UINT") {
    type = type == "INT" ? "an integer" : "a whole number >= 0";
  } else if (!type.empty()) {
    type = "of type " + type;
  } else {
    type = "a value of the option's type";
  }
  const std::string where = cmd == &app ? "" : cmd->get_name() + ": ";
  return where + name + ": " + common::Quote(value) + " is not " + type + "; `rocklab help " +
         (cmd == &app ? std::string() : cmd->get_name()) + "` says what it takes";
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
         "rocklab --version: the version; docs/commands.md: every command in full\n";
  return out;
}

}  // namespace rocklab::tools
