// rocklab record: the lab's LCM recorder (record/recorder.h): every event of
// the channels asked for, to an LCM log (rotated by size or time), with
// per-channel counts, losses and sequence gaps, and a summary on
// SIGINT/SIGTERM.
//
// Two buses by default: the main one (--lcm-url) and RL_RAW's own
// (--raw-url, derived from --lcm-url: common/bus_urls.h; `same`, or a
// non-udpm URL: one bus), the same --channels on each, into one log.
//
// Threading model: this thread runs LCM's dispatch of both instances (a
// poll on their file descriptors, 100 ms, then handleTimeout(0) on each that
// is readable), whose handler only copies each event into the recorder's
// queue, so the log is in this thread's order of receipt; the
// recorder's writer thread writes the file. Every second this thread warns
// (once) when events were dropped. On SIGINT/SIGTERM (the handlers only set
// the stop flag): dispatch what LCM already holds for at most 0.3 s (data
// that keeps flowing does not hold the stop), Stop (the writer writes what
// is queued, flushes, closes), print the summary, write --summary.
#include <poll.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "common/bus_urls.h"
#include "common/logger_clock.h"
#include "common/provenance.h"
#include "common/text.h"
#include "record/recorder.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct RecordCommand {
  record::RecorderOptions options;
  std::string lcm_url;
  std::string raw_url;  ///< --raw-url (empty: derived from lcm_url)
  std::string summary_json;
  bool json{};
  double queue_mb{64};
};

// After SIGINT/SIGTERM, how long what is already in the sockets is still
// taken, s: the socket buffers (4-16 MiB) hold about 1 s of a 5x replay,
// but the stop must end the recording within a second, writing included.
constexpr double kDrainAfterStopS = 0.3;

long long RmemMax() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long long v = -1;
  in >> v;
  return in ? v : -1;
}

// The udpm socket buffer asked for when the URL names none: 16 MiB (~3 s of
// a 5x replay of a 1 kHz test, ~5 MB/s of datagrams), but no more than
// net.core.rmem_max, which caps it anyway (4 MiB on the 2-core test machine;
// the kernel doubles what it grants for its bookkeeping). Sets `asked`.
std::string RecorderUrl(const std::string& url, long long& asked) {
  std::string out = SubscriberUrl(url);
  asked = 0;
  const std::string given = "recv_buf_size=4194304";  // SubscriberUrl's
  if (out.rfind("udpm://", 0) == 0 && url.find("recv_buf_size=") == std::string::npos) {
    const long long rmem = RmemMax();
    asked = rmem > 0 ? std::min(16LL << 20, rmem) : 16LL << 20;
    const auto at = out.find(given);
    if (at != std::string::npos) out.replace(at, given.size(), "recv_buf_size=" + std::to_string(asked));
  }
  return out;
}

// Dispatches what the instances hold: waits up to `timeout_ms` for one to
// be readable, then handles each readable one without waiting. Returns the
// number of instances that dispatched, 0 on timeout, -1 when the wait failed
// (errno says why: EINTR for a signal) or an instance's handling did.
int HandleAll(const std::vector<lcm::LCM*>& lcms, int timeout_ms) {
  if (lcms.size() == 1) return lcms[0]->handleTimeout(timeout_ms);  // one bus: LCM's own wait
  pollfd fds[2]{};
  const std::size_t n = std::min<std::size_t>(lcms.size(), 2);
  for (std::size_t i = 0; i < n; ++i) fds[i] = pollfd{lcms[i]->getFileno(), POLLIN, 0};
  const int ready = ::poll(fds, n, timeout_ms);
  if (ready <= 0) return ready;
  int handled = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if ((fds[i].revents & POLLIN) == 0) continue;
    const int r = lcms[i]->handleTimeout(0);
    if (r < 0) return -1;
    handled += r > 0;
  }
  return handled;
}

void PrintSummary(const record::RecorderStats& s) {
  std::fprintf(stderr, "rocklab record: %lld events written (%lld received, %lld dropped), %lld bytes in %zu file%s\n",
               static_cast<long long>(s.events), static_cast<long long>(s.received),
               static_cast<long long>(s.dropped), static_cast<long long>(s.bytes), s.files.size(),
               s.files.size() == 1 ? "" : "s");
  std::fprintf(stderr, "  %-28s %10s %8s %8s %8s\n", "channel", "count", "dropped", "seq_gaps", "missing");
  for (const auto& c : s.channels) {
    // Channel names come from whoever publishes on the bus: escaped when
    // they hold anything but printable ASCII.
    const bool plain = std::all_of(c.name.begin(), c.name.end(), [](char ch) { return ch >= 0x20 && ch < 0x7f; });
    const std::string name = plain ? c.name : common::Quote(c.name, 64);
    std::fprintf(stderr, "  %-28s %10lld %8lld %8s %8s\n", name.c_str(), static_cast<long long>(c.count),
                 static_cast<long long>(c.dropped), c.seq.any ? std::to_string(c.seq.gaps).c_str() : "-",
                 c.seq.any ? std::to_string(c.seq.missing).c_str() : "-");
  }
}

int RunRecord(RecordCommand& c) {
  Require(c.queue_mb >= 0.0625 && c.queue_mb <= 65536, "--queue-mb", "in [0.0625, 65536] MiB", c.queue_mb);
  c.options.queue_bytes = static_cast<std::size_t>(c.queue_mb * 1048576.0);
  try {
    c.options.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  RefuseStandardOutput("LOG", c.options.out_path, "an LCM log is written to a file (rotated by size or time)");
  if (!c.summary_json.empty() && c.summary_json != "-") {
    std::ofstream probe(c.summary_json, std::ios::app);
    if (!probe) throw UsageError("--summary: cannot write '" + c.summary_json + "'");
  }
  const std::atomic<bool>& stop = InstallStopSignals();
  long long asked = 0;
  const std::string url = RecorderUrl(c.lcm_url, asked);
  std::string raw;
  try {
    raw = common::RawUrl(c.lcm_url, c.raw_url);  // "" when RL_RAW is on the main bus
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) throw UsageError("--lcm-url: cannot open LCM at '" + url + "'");
  std::unique_ptr<lcm::LCM> raw_lcm;
  std::vector<lcm::LCM*> buses{&lcm};
  if (!raw.empty()) {
    long long raw_asked = 0;
    raw = RecorderUrl(raw, raw_asked);
    raw_lcm = std::make_unique<lcm::LCM>(raw);
    if (!raw_lcm->good()) throw UsageError("--raw-url: cannot open LCM at '" + raw + "'");
    buses.push_back(raw_lcm.get());
  }
  const auto log = common::NamedLogger("record");
  if (asked > 0 && asked < (16LL << 20)) {
    log->info("net.core.rmem_max caps the udpm socket buffer at {} bytes (raise it for more)", asked);
  }
  // What made each file: its sidecar LOG.provenance.csv, written on the
  // writer thread as the file is closed (record/log_provenance.h); no
  // input files, so nothing hashed: the buses and channels say what it took.
  record::LogProvenance::Fields taken = {{"lcm_url", url}, {"channels", c.options.channels}};
  if (!raw.empty()) taken.emplace_back("raw_url", raw);
  record::LogProvenance provenance({}, taken);
  c.options.provenance = &provenance;
  std::unique_ptr<record::Recorder> recorder;
  try {
    recorder = std::make_unique<record::Recorder>(buses, c.options);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  std::fprintf(stderr, "rocklab record: recording '%s' from %s%s%s to %s\n", c.options.channels.c_str(),
               url.c_str(), raw.empty() ? "" : " and ", raw.c_str(), c.options.out_path.c_str());
  double last_check = common::HostNowS();
  int failures = 0;
  while (!stop.load()) {
    if (HandleAll(buses, 100) < 0) {
      // A signal interrupts LCM's wait: -1 then is no failure.
      if (stop.load()) break;
      if (++failures >= 10) {
        log->error("LCM failed 10 times in a row while receiving; stopping");
        break;
      }
      continue;
    }
    failures = 0;
    const double now = common::HostNowS();
    if (now - last_check >= 1.0) {
      last_check = now;
      if (const int64_t d = recorder->DropsSince(); d > 0) {
        log->warn("{} events dropped in the last second (queue full or write errors; counted per channel)", d);
      }
    }
  }
  // What arrived before the stop (datagrams already in the socket too) is
  // recorded: handle until 20 ms pass with nothing, for at most
  // kDrainAfterStopS. A stream that never pauses (a replay still running)
  // would otherwise hold the stop for as long as it runs.
  const double drain_end = common::HostNowS() + kDrainAfterStopS;
  while (common::HostNowS() < drain_end && HandleAll(buses, 20) > 0) {
  }
  recorder->Stop();
  const record::RecorderStats stats = recorder->Stats();
  PrintSummary(stats);
  if (provenance.errors() > 0) {
    std::fprintf(stderr, "rocklab record: %lld provenance sidecars could not be written (see above)\n",
                 static_cast<long long>(provenance.errors()));
  }
  try {
    nlohmann::json summary = nlohmann::json::parse(record::SummaryJson(stats));
    summary["provenance"] = nlohmann::json::parse(common::ProvenanceJson(common::MakeProvenance({})));
    for (const auto& [key, value] : taken) summary["provenance"][key] = value;
    WriteResult(summary, c.json, c.summary_json);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "rocklab: %s\n", e.what());
    return kFailureExit;
  }
  return stats.write_error.empty() && provenance.errors() == 0 ? 0 : kFailureExit;
}

}  // namespace

void RegisterRecord(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<RecordCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("record", "record LCM channels to a log, counting every loss");
  cmd->add_option("LOG", c->options.out_path, "output LCM log (with rotation: LOG's stem.NNNN.ext); each file's provenance beside it, FILE.provenance.csv")->required();
  cmd->add_option("--channels", c->options.channels, "LCM channel regex, matched against the whole name")
      ->capture_default_str();
  cmd->add_option("--rotate-size", c->options.rotate_bytes, "start a new file before one passes BYTES (0: never)");
  cmd->add_option("--rotate-seconds", c->options.rotate_seconds,
                  "start a new file every S seconds of receipt time (0: never)");
  cmd->add_option("--summary", c->summary_json, "summary JSON written at the end (- : standard output)");
  AddJsonFlag(*cmd, c->json);
  cmd->add_option("--queue-mb", c->queue_mb, "the recorder's queue, MiB")->capture_default_str();
  cmd->add_flag("--force", c->options.overwrite, "replace existing log files");
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  AddRawUrlOption(*cmd, c->raw_url);
  cmd->callback([c, &run] { run = [c] { return RunRecord(*c); }; });
}

}  // namespace rocklab::tools
