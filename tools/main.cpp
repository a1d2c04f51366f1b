// The `rocklab` command line: one binary, one subcommand per task.
#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <iterator>
#include <exception>
#include <string>
#include <vector>

#include "common/logger_clock.h"
#include "common/text.h"
#include "tools/cli.h"
#include "tools/version.h"
#ifdef ROCKLAB_HAVE_VIDEO
#include "tools/video_plugin.h"
#endif

namespace rocklab::tools {
void RegisterParams(CLI::App& app, CommandRun& run);
void RegisterSimulate(CLI::App& app, CommandRun& run);
void RegisterDemo(CLI::App& app, CommandRun& run);
void RegisterFit(CLI::App& app, CommandRun& run);
void RegisterReplay(CLI::App& app, CommandRun& run);
void RegisterModel(CLI::App& app, CommandRun& run);
void RegisterCompare(CLI::App& app, CommandRun& run);
void RegisterSynth(CLI::App& app, CommandRun& run);
void RegisterReconstruct(CLI::App& app, CommandRun& run);
void RegisterDaq(CLI::App& app, CommandRun& run);
void RegisterRun(CLI::App& app, CommandRun& run);
void RegisterMonitor(CLI::App& app, CommandRun& run);
void RegisterReport(CLI::App& app, CommandRun& run);
void RegisterRecord(CLI::App& app, CommandRun& run);
void RegisterSweep(CLI::App& app, CommandRun& run);
void RegisterInfo(CLI::App& app, CommandRun& run);
void RegisterExport(CLI::App& app, CommandRun& run);
void RegisterSpy(CLI::App& app, CommandRun& run);  // spy, logplayer-gui
#ifdef ROCKLAB_HAVE_VIDEO
void RegisterTrack(CLI::App& app, CommandRun& run);
void RegisterCameraCalibrate(CLI::App& app, CommandRun& run);
#endif
}  // namespace rocklab::tools

int main(int argc, char** argv) {
  using namespace rocklab::tools;
  rocklab::common::LoadLogLevels();  // SPDLOG_LEVEL=debug etc.
  // `rocklab --version [--load]`: the version, build type and optional
  // parts, before any command is registered (tools/version.h).
  if (argc >= 2 && std::string(argv[1]) == "--version" &&
      (argc == 2 || (argc == 3 && std::string(argv[2]) == "--load"))) {
    std::fputs(VersionText(argc == 3).c_str(), stdout);
    return 0;
  }

  CLI::App app{"rocklab: shake-table rocking-block laboratory"};
  app.require_subcommand(1);
  app.set_version_flag("--version", [] { return VersionText(false, /*final_newline=*/false); },
                       "the version, build type and optional parts; --version --load also opens the plugins");
  CommandRun run;
  // Every command by name, in `rocklab help`'s order; a registrar that adds
  // two commands is named twice, in a row.
  struct Command {
    const char* name;
    CommandRegistrar add;
  };
  static const Command kCommands[] = {
      {"params", &RegisterParams},
      {"simulate", &RegisterSimulate},
      {"demo", &RegisterDemo},
      {"fit", &RegisterFit},
      {"replay", &RegisterReplay},
      {"model", &RegisterModel},
      {"compare", &RegisterCompare},
      {"synth", &RegisterSynth},
      {"reconstruct", &RegisterReconstruct},
      {"daq", &RegisterDaq},
      {"run", &RegisterRun},
      {"monitor", &RegisterMonitor},
      {"report", &RegisterReport},
      {"record", &RegisterRecord},
      {"sweep", &RegisterSweep},
      {"sweep-plot", &RegisterSweep},
      {"info", &RegisterInfo},
      {"export", &RegisterExport},
      {"spy", &RegisterSpy},
      {"logplayer-gui", &RegisterSpy},
#ifdef ROCKLAB_HAVE_VIDEO
      {"track", &RegisterTrack},
      {"camera-calibrate", &RegisterCameraCalibrate},
#endif
  };
  // `rocklab COMMAND ...` registers that command alone: the others' options
  // cost start-up time (docs/performance.md, Start-up) and play no part in
  // parsing it. Anything else (help, an unknown or misspelt command, no
  // command) registers them all. tests/tools/startup_test.cpp compares each
  // command's --help with `rocklab help COMMAND`.
  const Command* named = nullptr;
  if (argc >= 2) {
    for (const Command& c : kCommands) {
      if (std::string(argv[1]) == c.name) named = &c;
    }
  }
  if (named != nullptr) {
    named->add(app, run);
  } else {
    for (std::size_t i = 0; i < std::size(kCommands); ++i) {
      if (i == 0 || kCommands[i].add != kCommands[i - 1].add) kCommands[i].add(app, run);
    }
    // The table must name what the registrars add, in order, or a command
    // named alone would register another.
    const std::vector<CLI::App*> added = app.get_subcommands({});
    for (std::size_t i = 0; i < std::max(added.size(), std::size(kCommands)); ++i) {
      const std::string table = i < std::size(kCommands) ? kCommands[i].name : "(nothing)";
      const std::string real = i < added.size() ? added[i]->get_name() : "(nothing)";
      if (table != real) {
        std::fprintf(stderr, "rocklab: internal error: command %zu is '%s', main's table says '%s'\n", i + 1,
                     real.c_str(), table.c_str());
        return kFailureExit;
      }
    }
  }
#ifdef ROCKLAB_HAVE_VIDEO
  RegisterVideoSources();  // --input video:FILE, v4l2:/dev/videoN: the plugin, opened then
#endif

  // Before CLI11 parses: bare `rocklab` and `rocklab help [COMMAND]`, an
  // unknown command or option named as such with the nearest known one
  // (CLI11 would report a misspelt required option as missing).
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
  auto find = [&app](const std::string& name) -> const CLI::App* {
    for (const CLI::App* sub : app.get_subcommands({})) {
      if (sub->get_name() == name) return sub;
    }
    return nullptr;
  };
  auto unknown_command = [&names](const std::string& word) {
    const std::string near = DidYouMean(word, names);
    std::fprintf(stderr, "rocklab: unknown command %s%s; `rocklab help` lists the commands\n",
                 rocklab::common::Quote(word).c_str(),
                 near.empty() ? "" : (" (did you mean " + near + "?)").c_str());
    return kUsageExit;
  };
  if (argc == 1) {
    std::fputs(CommandList(app).c_str(), stderr);
    return kUsageExit;
  }
  const std::string first = argv[1];
  if (first == "completion") {
    if (argc != 3 || std::string(argv[2]) != "bash") {
      std::fprintf(stderr, "rocklab completion: takes one shell, bash (rocklab completion bash)\n");
      return kUsageExit;
    }
    std::fputs(BashCompletion(app).c_str(), stdout);
    return 0;
  }
  if (first == "help") {
    if (argc == 2) {
      std::fputs(CommandList(app).c_str(), stdout);
      return 0;
    }
    const CLI::App* sub = find(argv[2]);
    if (sub == nullptr) return unknown_command(argv[2]);
    if (argc > 3) {
      std::fprintf(stderr, "rocklab help: takes one command (rocklab help %s)\n",
                   rocklab::common::Printable(argv[2]).c_str());
      return kUsageExit;
    }
    std::fputs(sub->help("rocklab").c_str(), stdout);
    return 0;
  }
  if (first[0] != '-') {
    const CLI::App* sub = find(first);
    if (sub == nullptr) return unknown_command(first);
    const std::string unknown = UnknownOption(*sub, std::vector<std::string>(argv + 2, argv + argc));
    if (!unknown.empty()) {
      std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(unknown).c_str());
      return kUsageExit;
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ConversionError& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(ConversionMessage(app, e.what())).c_str());
    return kUsageExit;
  } catch (const CLI::ValidationError& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(ValidationMessage(app, e.what())).c_str());
    return kUsageExit;
  } catch (const CLI::RequiredError& e) {
    // Every required option not given, in one message (CLI11 names the first).
    const std::string missing = MissingRequired(app);
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(missing.empty() ? ParseErrorMessage(app, e.what()) : missing).c_str());
    return kUsageExit;
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(ParseErrorMessage(app, e.what())).c_str());
    return kUsageExit;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(e.what()).c_str());
    return kUsageExit;
  }

  try {
    return run ? run() : kUsageExit;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(e.what()).c_str());
    return kUsageExit;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rocklab: %s\n", rocklab::common::PrintableLines(e.what()).c_str());
    return kFailureExit;
  }
}
