#pragma once
// Shared pieces of the `rocklab` command line: each subcommand lives in its
// own cmd_<name>.cpp and registers itself through a Register<Name> function
// listed in main.cpp.

#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json_fwd.hpp>

#include "pipeline/option_error.h"

namespace rocklab::compare {
class CompareNode;
}
namespace rocklab::daq {
struct DaqNodeStats;
}
namespace rocklab::model {
class ModelNode;
}
namespace rocklab::pipeline {
struct DaqStageOptions;
}

namespace rocklab::tools {

/// A bad command line or a non-physical value: main prints `rocklab: <what>`
/// on one line and exits with kUsageExit. (The pipeline library's error, so
/// the library and the commands name options the same way.)
using UsageError = pipeline::OptionError;
using pipeline::Require;

inline constexpr int kUsageExit = 2;    ///< bad option, value or input file
inline constexpr int kFailureExit = 1;  ///< the command ran and failed
/// Input problems printed one by one before the rest are only counted.
inline constexpr int kShownProblems = 20;

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

/// The folder `file` goes into exists and may be written; else a
/// UsageError naming `option` (checked before the work, so a typo in an
/// output path costs nothing and exits as a usage error). "" and "-"
/// (standard output) pass.
void RequireOutputFolder(const std::string& option, const std::string& file);

/// Adds `--json` to `cmd` (into `json`): the command prints its result
/// object on standard output instead of its text summary.
CLI::Option* AddJsonFlag(CLI::App& cmd, bool& json);

/// A command's result object, the one `--json` prints and `--summary FILE`
/// holds (one code path builds it; this writes it): to `summary_path`
/// whole or not at all ("" none, "-" standard output), and with `json` on
/// standard output, or on stderr when `stdout_taken` (the command's data
/// went to standard output, `--out -`). Throws naming `summary_option`
/// when the file cannot be written.
void WriteResult(const nlohmann::json& result, bool json, const std::string& summary_path = "",
                 bool stdout_taken = false, const char* summary_option = "--summary");

/// `run`'s and `compare`'s end: the comparison tables on standard output
/// (not with `json`) and their JSON by WriteResult, with the keys of
/// `extra` (an object; run's `provenance`) added when given.
void WriteCompareResult(const compare::CompareNode& node, bool json, const std::string& summary_path,
                        const nlohmann::json* extra = nullptr);

/// `run`'s and `model`'s stack lines on standard error, each starting with
/// `what` ("run"): the impacts resolved by the stack model's assumptions
/// and the measured starts refused, when not 0.
void PrintStackAssumptions(const model::ModelNode& node, const char* what);

/// The DAQ stage of `daq` and `replay --rig`, with `json` its counts as
/// the result object (frames_read, published, ...) on standard output.
int RunDaqStageCommand(pipeline::DaqStageOptions& options, const char* what, bool json);

/// `path` as a file a reader opens: itself, or for `-` standard input
/// copied whole into a temporary file `stdin`*`suffix` in a folder of its
/// own (the readers take the format from the name and some read the start
/// twice; a sweep names a record by its file name), removed when the
/// command exits. With `hdf5_suffix`, bytes that start with HDF5's
/// signature get that suffix instead. Standard input can be read once: a
/// second `-` is a UsageError naming `option`. Messages and log lines show
/// the temporary as `<stdin>` (common::ShowPathAs).
std::string InputFile(const std::string& option, const std::string& path, const char* suffix = ".csv",
                      const char* hdf5_suffix = nullptr);

/// An output of a command whose writer needs a path (it writes through
/// common::AtomicFile, or a library opens the name): `path` itself, or for
/// `-` (standard output) a temporary file named *`suffix` (the format
/// the name gives) that Finish() copies to standard output; the temporary
/// is removed when this is destroyed. A file stays whole or absent as its
/// writer makes it; standard output gets the bytes only once they are all
/// written.
class OutputTarget {
 public:
  /// @throws std::runtime_error naming `option` when the temporary cannot be made.
  OutputTarget(std::string option, std::string path, const char* suffix);
  ~OutputTarget();
  OutputTarget(const OutputTarget&) = delete;
  OutputTarget& operator=(const OutputTarget&) = delete;

  /// Where the writer writes.
  const std::string& path() const { return write_path_; }
  /// The path as given (for messages: "standard output" for `-`).
  std::string name() const { return standard_output() ? "standard output" : given_; }
  bool standard_output() const { return !temp_.empty(); }
  /// For `-`: the temporary's bytes to standard output, flushed; else
  /// nothing. @throws std::runtime_error naming the option on a failed read or write.
  void Finish();

 private:
  std::string option_;
  std::string given_;
  std::string write_path_;
  std::string temp_;  ///< the temporary of `-`, else ""
};

/// A usage error naming `option` for an output given as `-` (standard
/// output) whose format needs a file it can seek in or read back (HDF5,
/// `--resume`): `what` says which. Other paths pass.
void RefuseStandardOutput(const std::string& option, const std::string& path, const char* what);

/// The required options of the command `app` parsed that were not given,
/// in one message naming them all ("simulate: missing required options
/// --alpha, --p, --mu, --rate; ..."); "" when none is missing (CLI11
/// reports only the first, one run at a time). Call after CLI11's
/// RequiredError: what it parsed is counted by then.
std::string MissingRequired(const CLI::App& app);

/// `option` is required unless `alternative` is given (simulate's --alpha,
/// --p, --mu without --assembly): MissingRequired names it with the others,
/// as "--alpha (or --assembly)", and MissingUnlessGiven after a parse.
void RequiredUnless(CLI::Option* option, const CLI::Option* alternative);

/// After a successful parse of `cmd`: the options RequiredUnless made
/// conditional that are missing, all in one UsageError ("simulate: missing
/// required options --alpha, --p, --mu (or --assembly); ..."). No-op when
/// none is missing.
void CheckRequiredUnless(const CLI::App& cmd);

/// `-` given for `option`, whose reader needs a file it can seek in (an
/// LCM log): a UsageError saying so. Other paths pass.
void RefuseStandardInput(const std::string& option, const std::string& path, const char* what);

/// At most one of `outputs` (option name, path) is `-` (standard output);
/// else a UsageError naming the two.
void RequireOneStandardOutput(const std::vector<std::pair<std::string, std::string>>& outputs);

/// Edit distance between `a` and `b` (optimal string alignment:
/// insertions, deletions, substitutions and swaps of neighbours, each 1).
std::size_t EditDistance(std::string_view a, std::string_view b);

/// CLI11's "Could not convert: --alpha = abc" as the user needs it: the
/// command, the option, the value and the type expected ("simulate: --alpha:
/// 'abc' is not a number"); other messages as they are.
std::string ConversionMessage(const CLI::App& app, const std::string& what);

/// CLI11's messages of an option's check (CLI::NonNegativeNumber,
/// CLI::Range: "--lookahead: Value abc not in range 0.000000 to
/// 1797693...") as ConversionMessage's: a value not of the option's type
/// said so ("run: --lookahead: 'abc' is not an integer"), one out of range
/// with its bounds ("'-1' is not >= 0", "'5e6' is not in [0.01, 1e+06]");
/// other messages with the command's name before them.
std::string ValidationMessage(const CLI::App& app, const std::string& what);

/// Any other message of CLI11's parsing with the command's name before
/// it ("synth: --truth: At Most 1 required but received 2").
std::string ParseErrorMessage(const CLI::App& app, const std::string& what);

/// The name of `names` closest to `word` when it is close enough to be a
/// typo of it (edit distance at most 2, and at most a third of the longer
/// name), or when `word` is the start of exactly one name; else "".
std::string DidYouMean(std::string_view word, const std::vector<std::string>& names);

/// The first option of `args` (a subcommand's arguments, after its name)
/// that `cmd` does not have, as a one-line message naming it and the
/// nearest option it has ("unknown option --duraton (did you mean
/// --duration?)"); "" when every option is known. Run before CLI11 parses:
/// CLI11 checks required options first and would report a misspelt
/// required option as missing. Long options (`--name`, `--name=value`) and
/// one-letter short ones (`-h`) are checked; values (also negative numbers)
/// and whatever follows a bare `--` are not.
std::string UnknownOption(const CLI::App& cmd, const std::vector<std::string>& args);

/// `rocklab completion bash`: a bash completion script made from `app`'s
/// registered subcommands and their long options (the command table, so a
/// new command or option completes without editing it): the commands (and
/// help, completion, --version) as the first word, a command's options
/// after a `-`, file names otherwise.
std::string BashCompletion(const CLI::App& app);

/// The command list: one line per subcommand of `app` (name and
/// description), in registration order, with how to get one command's help.
std::string CommandList(const CLI::App& app);

}  // namespace rocklab::tools
