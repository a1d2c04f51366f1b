// rocklab spy [--lcm-url URL] [--print-command]
// rocklab logplayer-gui [LOG] [--lcm-url URL] [--print-command]
//
// LCM's Java tools with rocklab's types on the class path. Debian's
// lcm-spy and lcm-logplayer-gui wrappers do not start on bookworm: they pass
// -Xincgc, which Java 17 refuses, and their -cp overrides CLASSPATH (so
// rocklab's jar is never seen). These commands build the java command line
// themselves: lcm.jar and jchart2d's jar where their Debian packages
// installed them (dpkg-query -L), rocklab_lcmtypes.jar from this build or
// installation, and exec java (the process becomes the JVM: a signal to it
// reaches the tool).
#include <unistd.h>

#include <cstdio>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "tools/cli.h"

namespace rocklab::tools {
namespace {

namespace fs = std::filesystem;

struct JavaToolCommand {
  std::string lcm_url;
  std::string log_path;
  bool print_command{};
};

// The file named `name` among what the Debian package `package` installed,
// else /usr/share/java/<name>; empty when neither exists.
std::string PackageFile(const std::string& package, const std::string& name) {
  const std::string query = "dpkg-query -L " + package + " 2>/dev/null";  // fixed names only
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen(query.c_str(), "r"), ::pclose);
  if (pipe) {
    char line[4096];
    while (std::fgets(line, sizeof line, pipe.get()) != nullptr) {
      std::string path(line);
      while (!path.empty() && (path.back() == '\n' || path.back() == '\r')) path.pop_back();
      std::error_code ec;
      if (fs::path(path).filename() == name && fs::is_regular_file(path, ec)) return path;
    }
  }
  const std::string fallback = "/usr/share/java/" + name;
  std::error_code ec;
  return fs::is_regular_file(fallback, ec) ? fallback : std::string();
}

std::string RequirePackageFile(const std::string& package, const std::string& name) {
  std::string path = PackageFile(package, name);
  if (path.empty()) {
    throw std::runtime_error(name + " not found: install the Debian package " + package +
                             " (tools/setup.sh does)");
  }
  return path;
}

// rocklab's types jar: $ROCKLAB_LCMTYPES_JAR, else beside this binary's
// build tree (build/tools/rocklab -> build/lcm_types/) or installation
// (bin/rocklab -> share/rocklab/).
std::string TypesJar() {
  if (const char* env = std::getenv("ROCKLAB_LCMTYPES_JAR"); env != nullptr && *env != '\0') {
    std::error_code ec;
    if (!fs::is_regular_file(env, ec)) {
      throw std::runtime_error(std::string("ROCKLAB_LCMTYPES_JAR: no file '") + env + "'");
    }
    return env;
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  std::vector<fs::path> tried;
  if (!ec) {
    const fs::path dir = exe.parent_path();
    tried = {dir / ".." / "lcm_types" / "rocklab_lcmtypes.jar",
             dir / ".." / "share" / "rocklab" / "rocklab_lcmtypes.jar"};
  }
  tried.emplace_back("/usr/share/rocklab/rocklab_lcmtypes.jar");
  for (const fs::path& p : tried) {
    if (fs::is_regular_file(p, ec)) return fs::weakly_canonical(p, ec).string();
  }
  std::string list;
  for (const fs::path& p : tried) list += (list.empty() ? "" : ", ") + p.lexically_normal().string();
  throw std::runtime_error("rocklab_lcmtypes.jar not found (tried " + list +
                           "); the build makes it when javac and lcm.jar are present "
                           "(default-jdk-headless, liblcm-java)");
}

// One argument as a POSIX shell reads it back.
std::string ShellQuoted(const std::string& arg) {
  if (!arg.empty() && arg.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                            "0123456789-_./:=+,@%") == std::string::npos) {
    return arg;
  }
  std::string out = "'";
  for (char c : arg) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Prints the command, or replaces this process with it.
int ExecJava(const std::string& tool, const std::vector<std::string>& argv, bool print_only) {
  if (print_only) {
    std::string line;
    for (const std::string& a : argv) line += (line.empty() ? "" : " ") + ShellQuoted(a);
    std::printf("%s\n", line.c_str());
    return 0;
  }
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((display == nullptr || *display == '\0') && (wayland == nullptr || *wayland == '\0')) {
    std::fprintf(stderr,
                 "rocklab: %s opens a window and there is no DISPLAY (log in with ssh -X, or "
                 "start it under xvfb-run for a headless check)\n",
                 tool.c_str());
    return kFailureExit;
  }
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::fflush(stdout);
  ::execvp(args[0], args.data());
  std::fprintf(stderr, "rocklab: cannot start java: %s (Debian: default-jre)\n",
               std::strerror(errno));
  return kFailureExit;
}

// -Djava.net.preferIPv4Stack: LCM's udpm is IPv4 multicast. No -Xincgc
// (removed in Java 9) and no -server (ignored).
std::vector<std::string> JavaCommand(const std::string& max_heap, const std::string& classpath,
                                     const std::string& main_class) {
  return {"java", "-Djava.net.preferIPv4Stack=true", "-Xmx" + max_heap, "-ea", "-cp", classpath,
          main_class};
}

int RunSpy(const JavaToolCommand& c) {
  const std::string classpath = RequirePackageFile("liblcm-java", "lcm.jar") + ":" +
                                RequirePackageFile("libjchart2d-java", "jchart2d.jar") + ":" +
                                TypesJar();
  std::vector<std::string> argv = JavaCommand("256m", classpath, "lcm.spy.Spy");
  if (!c.lcm_url.empty()) argv.push_back("--lcm-url=" + c.lcm_url);
  return ExecJava("lcm-spy", argv, c.print_command);
}

int RunLogPlayer(const JavaToolCommand& c) {
  if (!c.log_path.empty()) {
    std::error_code ec;
    if (!fs::is_regular_file(c.log_path, ec)) {
      throw UsageError("log '" + c.log_path + "' does not exist or is not a file");
    }
  }
  const std::string classpath = RequirePackageFile("liblcm-java", "lcm.jar") + ":" + TypesJar();
  std::vector<std::string> argv = JavaCommand("128m", classpath, "lcm.logging.LogPlayer");
  if (!c.lcm_url.empty()) argv.push_back("--lcm-url=" + c.lcm_url);
  if (!c.log_path.empty()) argv.push_back(c.log_path);
  return ExecJava("lcm-logplayer-gui", argv, c.print_command);
}

}  // namespace

void RegisterSpy(CLI::App& app, CommandRun& run) {
  {
    auto c = std::make_shared<JavaToolCommand>();  // shared: owned by the callback
    CLI::App* cmd = app.add_subcommand(
        "spy", "LCM's lcm-spy with rocklab's types: every channel live, decoded (needs a display)");
    cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL, else LCM's)");
    cmd->add_flag("--print-command", c->print_command, "print the java command instead of running it");
    cmd->callback([c, &run] { run = [c] { return RunSpy(*c); }; });
  }
  {
    auto c = std::make_shared<JavaToolCommand>();
    CLI::App* cmd = app.add_subcommand(
        "logplayer-gui", "LCM's log player window (lcm-logplayer-gui) with rocklab's types");
    cmd->add_option("log", c->log_path, "LCM log to open");
    cmd->add_option("--lcm-url", c->lcm_url, "LCM URL to play on (default: LCM_DEFAULT_URL, else LCM's)");
    cmd->add_flag("--print-command", c->print_command, "print the java command instead of running it");
    cmd->callback([c, &run] { run = [c] { return RunLogPlayer(*c); }; });
  }
}

}  // namespace rocklab::tools
