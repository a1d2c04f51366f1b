// `rocklab record` as the lab runs it: a process recording udpm:// (in a
// private network namespace on loopback, ttl=0: DESIGN.md), stopped by
// SIGINT, and its command-line errors.
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <utility>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "rocklab/raw_frame_t.hpp"
#include "tests/tools/run_cli.h"
#include "tests/tools/udpm_netns.h"
#include "tests/skip.h"
#include "tests/tools/log_count.h"

namespace rocklab::test {
namespace {

std::string EncodeRaw(int64_t seq) {
  rocklab::raw_frame_t m{};
  m.utime = seq * 1000;
  m.seq = seq;
  m.num_channels = 16;
  m.values.assign(16, 0.25 * static_cast<double>(seq));
  std::string buf(static_cast<std::size_t>(m.getEncodedSize()), '\0');
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

// The RL_RAW frames of the log files in `dir` (in file order): seq -> bytes
// in arrival order, and the order of the seqs.
struct LoggedFrames {
  std::vector<std::pair<int64_t, std::string>> frames;
  int64_t max_seq{-1};
};
LoggedFrames ReadFrames(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& f : std::filesystem::directory_iterator(dir)) {
    if (f.path().extension() == ".lcm") names.push_back(f.path().string());
  }
  std::sort(names.begin(), names.end());  // rec.0000.lcm, rec.0001.lcm, ...
  LoggedFrames out;
  for (const std::string& name : names) {
    lcm::LogFile f(name, "r");
    if (!f.good()) continue;
    while (const lcm::LogEvent* ev = f.readNextEvent()) {
      if (ev->channel != "RL_RAW") continue;
      rocklab::raw_frame_t m;
      if (m.decode(ev->data, 0, ev->datalen) < 0) continue;
      out.frames.emplace_back(m.seq, std::string(static_cast<const char*>(ev->data),
                                                 static_cast<std::size_t>(ev->datalen)));
      out.max_seq = std::max(out.max_seq, m.seq);
    }
  }
  return out;
}

// Oracle: what the test published and what the recorder says it lost.
// 20 000 RL_RAW frames (the size of a lab rig's frame) at up to 10 kHz with
// seq 100..104 never sent (a source gap of 5), plus RL_EVENT and a channel
// outside --channels. UDP multicast may lose a datagram (a full socket
// buffer on a loaded machine), so no count is expected exactly: every frame
// the sender sent (publish() returned 0) must be either in the log,
// byte for byte and in order, or among the frames the recorder reports
// missing (seq_missing, which counts its own queue's drops too); the
// summary's counts must equal the log's (no lossy path between them); the
// files rotate every 500 kB under LOG's stem.NNNN.lcm. After the burst, the
// test keeps sending frames seq 20000, 20001, ... until one is in the log:
// the recorder writes in arrival order, so every earlier frame that arrived
// is written by then (a condition with a deadline, not a fixed sleep), and a
// lost frame of the burst lies between two logged ones, where seq_missing
// sees it. Sanity bound: at most 10 % lost (loopback loses only on a full
// buffer; a recorder that loses more is broken, not loaded).
TEST(RecordUdpmTest, RecordsEveryFrameAndCountsTheSourceGap) {
  const std::string why = EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string dir = ScratchDir("record_udpm");
  const std::string log = dir + "/rec.lcm", summary = dir + "/rec.json";
  const pid_t pid = StartCli({"record", log, "--channels", "RL_.*", "--rotate-size", "500000", "--summary", summary,
                              "--force", "--lcm-url", kUdpmUrl},
                             dir + "/out", dir + "/err");
  ASSERT_FALSE(WaitForLine(dir + "/err", "rocklab record: recording").empty()) << ReadFile(dir + "/err");
  lcm::LCM lcm(kUdpmUrl);
  ASSERT_TRUE(lcm.good());
  std::map<int64_t, std::string> sent;  // seq -> bytes, of the frames publish() sent
  int64_t not_sent = 0, events_sent = 0;
  const int n = 20000;
  const auto publish = [&](int64_t seq) {
    std::string frame = EncodeRaw(seq);
    if (lcm.publish("RL_RAW", frame.data(), static_cast<unsigned>(frame.size())) == 0) {
      sent.emplace(seq, std::move(frame));
    } else {
      ++not_sent;
    }
  };
  for (int64_t seq = 0; seq < n; ++seq) {
    if (seq >= 100 && seq < 105) continue;
    publish(seq);
    if (seq % 1000 == 0) events_sent += lcm.publish("RL_EVENT", "e", 1) == 0 ? 1 : 0;
    lcm.publish("NOT_RECORDED", "x", 1);
    if (seq % 10 == 9) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  int64_t next_seq = n;
  EXPECT_TRUE(WaitUntil([&] {
    publish(next_seq++);
    return ReadFrames(dir).max_seq >= n;
  })) << "no frame after the burst reached the log";
  EXPECT_EQ(StopProcess(pid, SIGINT), 0) << ReadFile(dir + "/err");
  EXPECT_EQ(not_sent, 0) << "publish() failed on loopback";

  const LoggedFrames logged = ReadFrames(dir);
  ASSERT_FALSE(logged.frames.empty());
  int64_t previous = -1, gaps = 0, missing = 0;
  for (const auto& [seq, bytes] : logged.frames) {
    ASSERT_GT(seq, previous) << "out of order";
    if (previous >= 0 && seq > previous + 1) {
      ++gaps;
      missing += seq - previous - 1;
    }
    previous = seq;
    const auto it = sent.find(seq);
    ASSERT_NE(it, sent.end()) << "frame " << seq << " was never sent";
    EXPECT_EQ(bytes, it->second) << "frame " << seq;
  }
  // The sender's frames in the logged range that the log lacks: exactly the
  // recorder's seq_missing, less the 5 never sent.
  const int64_t first = logged.frames.front().first, last = logged.frames.back().first;
  int64_t sent_in_range = 0;
  for (const auto& [seq, bytes] : sent) sent_in_range += seq >= first && seq <= last ? 1 : 0;
  const int64_t lost = sent_in_range - static_cast<int64_t>(logged.frames.size());
  EXPECT_EQ(first, 0) << "the first frame was lost: no counter can see that";
  EXPECT_LE(lost, n / 10) << "lost " << lost << " of " << sent_in_range;

  const auto j = nlohmann::json::parse(ReadFile(summary));
  ASSERT_EQ(j["channels"].size(), 2u) << j.dump();
  const auto& raw = j["channels"][0];
  EXPECT_EQ(raw["name"], "RL_RAW");
  EXPECT_EQ(raw["count"], static_cast<int64_t>(logged.frames.size()));
  EXPECT_EQ(raw["seq_gaps"], gaps);
  EXPECT_EQ(raw["seq_missing"], missing);
  EXPECT_EQ(raw["seq_missing"].get<int64_t>(), lost + 5) << "sent " << sent_in_range << ", logged "
                                                          << logged.frames.size();
  EXPECT_GE(raw["seq_gaps"].get<int64_t>(), 1);  // the source gap
  EXPECT_EQ(raw["seq_back"], 0);
  EXPECT_EQ(raw["received"].get<int64_t>(), raw["count"].get<int64_t>() + raw["dropped"].get<int64_t>());
  EXPECT_EQ(j["channels"][1]["name"], "RL_EVENT");
  int64_t events_logged = 0;
  const auto files = j["files"].get<std::vector<std::string>>();
  for (const std::string& f : files) events_logged += CountLogEvents(f, "RL_EVENT");
  EXPECT_EQ(j["channels"][1]["count"], events_logged);
  EXPECT_LE(events_logged, events_sent);
  ASSERT_GE(files.size(), 5u);  // ~2.9 MB in 500 kB files
  int64_t last_event = -1, last_utime = 0;
  for (std::size_t i = 0; i < files.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/rec.%04zu.lcm", i);
    EXPECT_EQ(files[i], dir + name);
    lcm::LogFile f(files[i], "r");
    ASSERT_TRUE(f.good()) << files[i];
    while (const lcm::LogEvent* ev = f.readNextEvent()) {
      EXPECT_EQ(ev->eventnum, last_event + 1);
      EXPECT_GE(ev->timestamp, last_utime);
      last_event = ev->eventnum;
      last_utime = ev->timestamp;
    }
  }
}

// SIGTERM while data flows (a publisher that never pauses
// for 20 ms, as a 1x or 20x replay does): the recorder stops within a
// second, writing what it holds, rather than draining a stream that does not
// end. Oracle: the publisher is still sending when the recorder exits (so
// the stop did not wait for the data to end); exit 0 within the deadline;
// the summary's counts match the log (every event received is written or
// counted as dropped), and a channel name's escape bytes reach stderr
// escaped. The deadline (5 s) is generous for a loaded 2-core
// machine; the time measured is printed.
TEST(RecordUdpmTest, SigtermStopsWithinASecondWhileDataFlows) {
  const std::string why = EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string dir = ScratchDir("record_term");
  const std::string log = dir + "/term.lcm", summary = dir + "/term.json";
  const pid_t pid = StartCli({"record", log, "--channels", "RL_.*", "--summary", summary, "--force", "--lcm-url",
                              kUdpmUrl},
                             dir + "/out", dir + "/err");
  ASSERT_FALSE(WaitForLine(dir + "/err", "rocklab record: recording").empty()) << ReadFile(dir + "/err");
  std::atomic<bool> publishing{true};
  std::atomic<int64_t> sent{0};
  std::atomic<bool> publisher_done{false};
  std::thread publisher([&] {
    lcm::LCM lcm(kUdpmUrl);
    lcm.publish("RL_\x1b]0;title\x07", "x", 1);  // a name with a terminal escape, for the summary
    const auto start = std::chrono::steady_clock::now();
    for (int64_t seq = 0; publishing.load() && std::chrono::steady_clock::now() - start < std::chrono::seconds(60);
         ++seq) {
      const std::string m = EncodeRaw(seq);
      lcm.publish("RL_RAW", m.data(), static_cast<unsigned>(m.size()));
      sent = seq + 1;
      if (seq % 5 == 4) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // ~4 kHz, never idle 20 ms
    }
    publisher_done = true;
  });
  const bool flowing = WaitUntil([&] { return CountLogEvents(log, "RL_RAW") >= 2000; }, 30.0);
  const auto term = std::chrono::steady_clock::now();
  const int code = StopProcess(pid, SIGTERM, 5.0);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - term).count();
  const bool still_sending = !publisher_done.load();
  publishing = false;
  publisher.join();
  ASSERT_TRUE(flowing) << ReadFile(dir + "/err");
  EXPECT_EQ(code, 0) << "still running " << took_s << " s after SIGTERM\n" << ReadFile(dir + "/err");
  EXPECT_TRUE(still_sending);
  std::printf("record stopped %.3f s after SIGTERM, %lld frames sent\n", took_s,
              static_cast<long long>(sent.load()));
  const auto j = nlohmann::json::parse(ReadFile(summary));
  ASSERT_EQ(j["channels"].size(), 2u) << j.dump();
  const auto& raw = j["channels"][0]["name"] == "RL_RAW" ? j["channels"][0] : j["channels"][1];
  EXPECT_EQ(raw["name"], "RL_RAW");
  EXPECT_EQ(raw["count"].get<int64_t>(), CountLogEvents(log, "RL_RAW"));
  EXPECT_EQ(raw["received"].get<int64_t>(), raw["count"].get<int64_t>() + raw["dropped"].get<int64_t>());
  // The summary on stderr escapes the channel's name.
  const std::string err = ReadFile(dir + "/err");
  EXPECT_EQ(err.find('\x1b'), std::string::npos) << err;
  EXPECT_NE(err.find("'RL_\\x1b]0;title\\x07'"), std::string::npos) << err;
}

// Oracle: docs/reliability.md's contract for bad input: one line naming the file or
// option, exit code 2 (memq://, so no network is needed).
TEST(RecordUdpmTest, BadOptionsAndExistingLogsAreUsageErrors) {
  const std::string dir = ScratchDir("record_cli");
  const std::string log = dir + "/exists.lcm";
  WriteFile(log, "an earlier test");
  CliResult r = RunCli({"record", log, "--lcm-url", "memq://"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(log), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--force"), std::string::npos) << r.err;
  EXPECT_EQ(ReadFile(log), "an earlier test");
  r = RunCli({"record", dir + "/x.lcm", "--rotate-seconds", "-1", "--lcm-url", "memq://"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--rotate-seconds"), std::string::npos) << r.err;
  r = RunCli({"record", dir + "/no_such_dir/x.lcm", "--lcm-url", "memq://"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no_such_dir/x.lcm"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace rocklab::test
