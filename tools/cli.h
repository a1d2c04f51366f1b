#pragma once
// Shared pieces of the `rocklab` command line: each subcommand lives in its
// own cmd_<name>.cpp and registers itself through a Register<Name> function
// listed in main.cpp.

#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

#include "pipeline/option_error.h"

namespace rocklab::tools {

/// A bad command line or a non-physical value: main prints `rocklab: <what>`
/// on one line and exits with kUsageExit. (The pipeline library's error, so
/// the library and the commands name options the same way.)
using UsageError = pipeline::OptionError;
using pipeline::Require;

inline constexpr int kUsageExit = 2;    ///< bad option, value or input file
inline constexpr int kFailureExit = 1;  ///< the command ran and failed

/// What a subcommand runs once its options are parsed; returns the exit code.
using CommandRun = std::function<int()>;

/// Adds a subcommand to `app`; its callback stores the command's run function
/// into `run` so that main calls it outside CLI11's parsing.
using CommandRegistrar = void (*)(CLI::App& app, CommandRun& run);

/// Installs SIGINT/SIGTERM handlers that only set the returned flag (nodes
/// poll it in their loops), and ignores SIGPIPE. Idempotent.
const std::atomic<bool>& InstallStopSignals();

/// The LCM URL a subscribing node opens for `url` (empty: LCM_DEFAULT_URL,
/// else LCM's own default udpm://239.255.76.67:7667?ttl=0). A udpm URL
/// without recv_buf_size gets recv_buf_size=4194304 (bytes; the kernel caps
/// it at net.core.rmem_max): the default 208 KiB socket buffer holds only
/// some 50 ms of a 1 kHz test's datagrams, and what overflows it is lost
/// before LCM sees it. Other URLs are returned as they are.
std::string SubscriberUrl(const std::string& url);

/// Adds `--raw-url URL` (into `raw_url`) to `cmd`: where RL_RAW goes or is
/// read; default derived from --lcm-url, `same`: the main bus
/// (common/bus_urls.h, docs/channels.md).
CLI::Option* AddRawUrlOption(CLI::App& cmd, std::string& raw_url);


}  // namespace rocklab::tools
