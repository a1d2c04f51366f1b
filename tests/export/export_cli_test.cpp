// `rocklab info` and `rocklab export` as a researcher runs them.
//
// Oracle: a log built here with known contents (counts, sample clock,
// sequence gaps, an undecodable message, an unknown type, 100 bytes of
// damage, one RL_DAQ_CONFIG) and the definitions in docs/export.md; for raw
// files the DAQ's own source.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <pty.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <nlohmann/json.hpp>

#include "common/lcm_log.h"
#include "daq/source.h"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/export/readback.h"
#include "tests/sha256sum.h"
#include "tests/tools/run_cli.h"

namespace rocklab {
namespace {

template <class Msg>
void Put(common::LogWriter& w, const std::string& channel, const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  ASSERT_TRUE(w.Write(channel, buf.data(), buf.size(), m.utime));
}

// RL_DAQ_CONFIG once; RL_RAW seq 0,1,2,5,6 at 1 kHz from t = 10 s (a gap of
// 2), then one truncated raw frame; RL_TABLE 3 messages; FOREIGN 2 events
// of another type; 100 bytes of damage between the two halves.
std::string MakeLog(const std::string& dir) {
  const std::string a = dir + "/a.lcm", b = dir + "/b.lcm", out = dir + "/test.lcm";
  const std::int64_t t0 = 10'000'000;
  {
    common::LogWriter w(a);
    rocklab::daq_config2_t c{};
    c.utime = t0;
    c.rig_name = "block1";
    c.calibration_id = "cal-2026-11";
    c.sample_rate_hz = 1000;
    c.num_channels = 2;
    c.channel_names = {"mirror_s", "table_disp"};
    c.channel_units = {"m", "m"};
    c.channel_sensors = {"mirror_x", "table_disp"};
    c.gain = {1, 0.001};
    c.offset = {0, 0};
    c.alpha = 0.25;
    c.p = 2.5;
    c.mu = 0.9;
    Put(w, "RL_DAQ_CONFIG", c);
    for (std::int64_t seq : {0, 1, 2}) {
      rocklab::raw_frame_t r{};
      r.utime = t0 + seq * 1000;
      r.seq = seq;
      r.num_channels = 2;
      r.values = {0.5 * static_cast<double>(seq), std::nan("")};
      Put(w, "RL_RAW", r);
    }
    const std::uint8_t foreign[12] = {1, 2, 3, 4, 5, 6, 7, 8, 0, 0, 0, 0};
    EXPECT_TRUE(w.Write("FOREIGN", foreign, sizeof foreign, t0));
    EXPECT_TRUE(w.Write("FOREIGN", foreign, sizeof foreign, t0));
  }
  {
    common::LogWriter w(b);
    for (std::int64_t seq : {5, 6}) {
      rocklab::raw_frame_t r{};
      r.utime = t0 + seq * 1000;
      r.seq = seq;
      r.num_channels = 2;
      r.values = {1.0, 2.0};
      Put(w, "RL_RAW", r);
    }
    for (int k = 0; k < 3; ++k) {
      rocklab::table_state_t t{};
      t.utime = t0 + k * 1000;
      t.seq = k;
      t.acceleration = 0.5 * k;
      Put(w, "RL_TABLE", t);
    }
    rocklab::raw_frame_t r{};
    r.num_channels = 2;
    r.values = {1.0, 2.0};
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(r.getEncodedSize()));
    r.encode(buf.data(), 0, static_cast<int>(buf.size()));
    EXPECT_TRUE(w.Write("RL_RAW", buf.data(), buf.size() - 4, t0 + 7000));  // cut: undecodable
  }
  std::ofstream o(out, std::ios::binary);
  o << test::ReadFile(a) << std::string(100, 'x') << test::ReadFile(b);
  return out;
}

class InfoExport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::ScratchDir("info_export");
    log_ = MakeLog(dir_);
  }
  std::string dir_, log_;
};

TEST_F(InfoExport, InfoJsonSaysWhatTheLogHolds) {
  const auto r = test::RunCli({"info", log_, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "lcm_log");
  EXPECT_EQ(j["damaged_bytes"], 100);
  EXPECT_EQ(j["damaged_regions"], 1);
  EXPECT_NEAR(j["duration"].get<double>(), 0.006, 1e-9);  // 10.000 .. 10.006 s
  EXPECT_EQ(j["config"]["rig"], "block1");
  EXPECT_EQ(j["config"]["calibration"], "cal-2026-11");
  EXPECT_EQ(j["config"]["units"], (std::vector<std::string>{"m", "m"}));
  EXPECT_EQ(j["config"]["messages"], 1);
  std::map<std::string, nlohmann::json> ch;
  for (const auto& c : j["channels"]) ch[c["name"]] = c;
  ASSERT_EQ(ch.size(), 4u);
  const auto& raw = ch["RL_RAW"];
  EXPECT_EQ(raw["type"], "raw_frame_t");
  EXPECT_EQ(raw["count"], 6);
  EXPECT_EQ(raw["undecodable"], 1);
  EXPECT_EQ(raw["seq_gaps"], 1);
  EXPECT_EQ(raw["seq_missing"], 2);
  EXPECT_DOUBLE_EQ(raw["first_time"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(raw["last_time"].get<double>(), 10.006);
  EXPECT_NEAR(raw["rate_hz"].get<double>(), 4 / 0.006, 1e-6);  // 5 decoded over 6 ms
  EXPECT_EQ(ch["RL_TABLE"]["type"], "table_state_t");
  EXPECT_EQ(ch["RL_TABLE"]["seq_gaps"], 0);
  EXPECT_NEAR(ch["RL_TABLE"]["rate_hz"].get<double>(), 1000.0, 1e-6);
  EXPECT_EQ(ch["RL_DAQ_CONFIG"]["seq_gaps"], 0);  // daq_config2_t has a seq (daq_config_t: null, SeqLoss.*)
  EXPECT_EQ(ch["FOREIGN"]["type"], "unknown");
  EXPECT_EQ(ch["FOREIGN"]["count"], 2);
  EXPECT_EQ(ch["FOREIGN"]["fingerprint"], "0x0102030405060708");
  EXPECT_EQ(ch["FOREIGN"]["first_time"], nullptr);
}

TEST_F(InfoExport, InfoTextNamesTheUnknownTypeAndTheDamage) {
  const auto r = test::RunCli({"info", log_});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("unknown (fingerprint 0x0102030405060708)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("damaged:   1 regions, 100 bytes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rig:       block1, calibration cal-2026-11"), std::string::npos) << r.out;
}

TEST_F(InfoExport, InfoOfARawFileMatchesTheSource) {
  const std::string lvm = ROCKLAB_SOURCE_DIR "/data/samples/slip.lvm";
  const auto r = test::RunCli({"info", lvm, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  auto source = daq::OpenSource(lvm, daq::SourceOptions{});
  daq::Frame f;
  std::int64_t rows = 0;
  double first = 0, last = 0;
  while (source->Next(f) == daq::ReadStatus::kFrame) {
    if (rows++ == 0) first = f.time_s;
    last = f.time_s;
  }
  EXPECT_EQ(j["kind"], "lvm");
  EXPECT_EQ(j["rows"], rows);
  EXPECT_EQ(j["bad_rows"], source->stats().bad_rows);
  EXPECT_EQ(j["segments"], source->stats().segments);
  EXPECT_GE(j["segments"].get<int>(), 1);
  EXPECT_DOUBLE_EQ(j["first_time"].get<double>(), first);
  EXPECT_DOUBLE_EQ(j["last_time"].get<double>(), last);
  EXPECT_DOUBLE_EQ(j["rate_hz"].get<double>(), source->sample_rate_hz());
  ASSERT_EQ(j["channels"].size(), source->channel_names().size());
  EXPECT_EQ(j["channels"][0]["name"], source->channel_names()[0]);
}

// Every bundled raw CSV has a time column: info and export need no --rate,
// with or without the rig, and the rate is the file's (1 kHz, the rig's
// sample_rate_hz that made them: data/samples/README.md). A --rate the
// time column contradicts is a usage error naming both.
TEST_F(InfoExport, BundledRawCsvsNeedNoRateAndAWrongOneIsNamed) {
  const std::string samples = ROCKLAB_SOURCE_DIR "/data/samples/";
  const std::string rig = ROCKLAB_SOURCE_DIR "/data/rigs/block1_rig.toml";
  for (const std::string name : {"fig7_block1.csv", "free_rocking.csv", "twist.csv", "free_block1.csv"}) {
    for (const bool with_rig : {false, true}) {
      std::vector<std::string> args{"info", samples + name, "--json"};
      if (with_rig) args.insert(args.end(), {"--rig", rig});
      const auto r = test::RunCli(args);
      ASSERT_EQ(r.exit_code, 0) << name << (with_rig ? " --rig" : "") << ": " << r.err;
      EXPECT_NEAR(nlohmann::json::parse(r.out)["rate_hz"].get<double>(), 1000.0, 1e-6) << name;
    }
    const auto e = test::RunCli({"export", samples + name, "--rig", rig, "--out", dir_ + "/raw.csv", "--quiet"});
    EXPECT_EQ(e.exit_code, 0) << name << ": " << e.err;
  }
  const auto bad = test::RunCli({"info", samples + "fig7_block1.csv", "--rate", "500"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("the time column gives a sample rate of 1000 Hz, but --rate is 500 Hz"), std::string::npos)
      << bad.err;
  const auto bad_export =
      test::RunCli({"export", samples + "fig7_block1.csv", "--rate", "2000", "--out", dir_ + "/x.csv"});
  EXPECT_EQ(bad_export.exit_code, 2);
  EXPECT_NE(bad_export.err.find("but --rate is 2000 Hz"), std::string::npos) << bad_export.err;
  // A 500 Hz file against the 1 kHz rig: the rig's rate, named with its file.
  const std::string slow = dir_ + "/slow.csv";
  std::ofstream(slow) << "time,mirror_s\n0,0\n0.002,0\n0.004,0\n";
  const auto rig_bad = test::RunCli({"info", slow, "--rig", rig});
  EXPECT_EQ(rig_bad.exit_code, 2);
  EXPECT_NE(rig_bad.err.find("gives a sample rate of 500 Hz, but the rig's sample_rate_hz (" + rig + ") is 1000 Hz"),
            std::string::npos)
      << rig_bad.err;
  EXPECT_EQ(test::RunCli({"info", slow}).exit_code, 0);  // no rig, no --rate: the file's 500 Hz
}

TEST_F(InfoExport, ExportWritesTheLogAndSaysTheDamage) {
  const std::string out = dir_ + "/test.h5";
  const auto r = test::RunCli({"export", log_, "--out", out, "--channels", "RL_(RAW|TABLE)"});
  // The damage makes the exit code 1 (as every log-reading command); the
  // rest is exported.
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("is damaged"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 undecodable"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "a progress bar on a pipe";
  EXPECT_EQ(test::H5Groups(out), (std::vector<std::string>{"RL_RAW", "RL_TABLE"}));
  const auto raw = test::ReadH5Table(out, "RL_RAW");
  // time utime seq num_channels values_0 values_1, then the channels by
  // RL_DAQ_CONFIG's names (raw: the default).
  ASSERT_EQ(raw.size(), 8u);
  EXPECT_EQ(raw[4].name, "values_0");
  EXPECT_EQ(raw[4].real, (std::vector<double>{0, 0.5, 1.0, 1.0, 1.0}));
  EXPECT_EQ(raw[2].integer, (std::vector<std::int64_t>{0, 1, 2, 5, 6}));
  EXPECT_EQ(raw[6].name, "mirror_s");
  EXPECT_EQ(raw[6].real, raw[4].real);
  EXPECT_EQ(raw[7].name, "table_disp");
  EXPECT_EQ(raw[7].unit, "");
}

// Nothing selected is an error, and writes nothing (issue 36: it exited 0
// with an empty file).
TEST_F(InfoExport, ExportWithNoChannelSelectedIsAnErrorAndWritesNothing) {
  const std::string out = dir_ + "/none.h5";
  const auto r = test::RunCli({"export", log_, "--out", out, "--channels", "RL_NOPE"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("--channels 'RL_NOPE' selects"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nothing written"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// A CSV export's provenance sidecar (docs/provenance.md): key,value rows,
// the log's SHA-256 as coreutils' sha256sum gives it (the oracle).
TEST_F(InfoExport, CsvExportWritesItsProvenanceBeside) {
  const std::string out = dir_ + "/prov.csv";
  const auto r = test::RunCli({"export", log_, "--out", out, "--channels", "RL_TABLE"});
  EXPECT_NE(r.err.find("prov.provenance.csv"), std::string::npos) << r.err;
  const auto table = test::ReadCsvTable(dir_ + "/prov.provenance.csv");
  ASSERT_EQ(table.size(), 2u);
  ASSERT_EQ(table[0].name, "key");
  std::map<std::string, std::string> p;
  for (std::size_t i = 0; i < table[0].text.size(); ++i) p[table[0].text[i]] = table[1].text[i];
  const std::string hash = test::Sha256sum(log_);
  ASSERT_EQ(hash.size(), 64u);
  EXPECT_EQ(p["source_1"], log_ + " (" + std::to_string(std::filesystem::file_size(log_)) + " bytes, sha256 " +
                               hash + ")");
  EXPECT_NE(p["command"].find("export " + log_ + " --out " + out), std::string::npos) << p["command"];
  EXPECT_EQ(p.count("rocklab_version") + p.count("build_type") + p.count("created_utc"), 3u);
}

// --calibrated: gain * raw + offset in the channel's unit (oracle: the
// config written above: mirror_s gain 1 offset 0 in m); --raw with it is a
// usage error; --help says both.
TEST_F(InfoExport, ExportCalibratedNamesTheRawChannelsInTheirUnits) {
  const std::string out = dir_ + "/cal.h5";
  const auto r = test::RunCli({"export", log_, "--out", out, "--channels", "RL_RAW", "--calibrated"});
  EXPECT_EQ(r.exit_code, 1) << r.err;  // the log's damage
  const auto raw = test::ReadH5Table(out, "RL_RAW");
  ASSERT_EQ(raw.size(), 8u);
  EXPECT_EQ(raw[6].name, "mirror_s");
  EXPECT_EQ(raw[6].unit, "m");
  EXPECT_EQ(raw[6].real, raw[4].real);
  EXPECT_EQ(test::RunCli({"export", log_, "--out", out, "--raw", "--calibrated"}).exit_code, 2);
  // A raw file holds no RL_DAQ_CONFIG: --calibrated there is refused, not ignored.
  const auto on_raw = test::RunCli({"export", ROCKLAB_SOURCE_DIR "/data/samples/slip.lvm", "--out", dir_ + "/raw.h5",
                                    "--calibrated"});
  EXPECT_EQ(on_raw.exit_code, 2) << on_raw.err;
  EXPECT_NE(on_raw.err.find("--calibrated: logs only"), std::string::npos) << on_raw.err;
  const auto help = test::RunCli({"export", "--help"});
  EXPECT_NE(help.out.find("--calibrated"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("--raw"), std::string::npos) << help.out;
}

TEST_F(InfoExport, ExportRefusesAnUnknownExtension) {
  const auto r = test::RunCli({"export", log_, "--out", dir_ + "/x.parquet"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(".csv, .mat or .h5"), std::string::npos) << r.err;
}

TEST_F(InfoExport, ExportOfAMissingInputIsAUsageErrorNamingIt) {
  const auto r = test::RunCli({"export", dir_ + "/missing.lvm", "--out", dir_ + "/m.h5"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("INPUT: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("missing.lvm"), std::string::npos) << r.err;
}

// Oracle: the bytes of the previous export, read before the failed one;
// the folder's listing (no file under a new name, no temporary).
TEST_F(InfoExport, AFailedExportLeavesThePreviousFileByteForByte) {
  // An input that is not there (a typo) and one that is there but unreadable
  // as a raw file (it fails after the output was opened).
  test::WriteFile(dir_ + "/empty.csv", "");
  for (const char* format : {".h5", ".mat", ".csv"}) {
    const std::string ext = format;
    const std::string out = dir_ + "/prev" + ext;
    const auto first = test::RunCli({"export", log_, "--out", out, "--channels", "RL_RAW"});
    ASSERT_EQ(first.exit_code, 1) << first.err;  // the log's damage
    const std::string written = ext == ".csv" ? dir_ + "/prev_RL_RAW.csv" : out;
    const std::string before = test::ReadFile(written);
    ASSERT_FALSE(before.empty());
    std::set<std::string> listing;
    for (const auto& e : std::filesystem::directory_iterator(dir_)) listing.insert(e.path().filename().string());
    for (const std::string& bad : {dir_ + "/tset.lcm", dir_ + "/empty.csv"}) {
      const auto r = test::RunCli({"export", bad, "--out", out});
      EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
      EXPECT_NE(r.err.find("INPUT: "), std::string::npos) << r.err;
      EXPECT_EQ(test::ReadFile(written), before) << ext << " after " << bad;
      std::set<std::string> after;
      for (const auto& e : std::filesystem::directory_iterator(dir_)) after.insert(e.path().filename().string());
      EXPECT_EQ(after, listing) << ext << " after " << bad;
    }
  }
}

// Oracle: a complete export of the same log made first. Killed at any
// moment, an export leaves the target either as it was or complete; the
// next export to the same target removes the killed one's temporary
// (issue 34: 40 MB left behind forever).
TEST_F(InfoExport, AKilledExportNeverLeavesATornFile) {
  const std::string big = dir_ + "/big.lcm";
  {
    common::LogWriter w(big);
    rocklab::raw_frame_t f{};
    f.num_channels = 8;
    f.values.assign(8, 0.25);
    for (int k = 0; k < 200000; ++k) {
      f.utime = 1'000'000 + 1000LL * k;
      f.seq = k;
      Put(w, "RL_RAW", f);
    }
  }
  const std::string complete = dir_ + "/complete.h5", out = dir_ + "/killed.h5";
  ASSERT_EQ(test::RunCli({"export", big, "--out", complete}).exit_code, 0);
  test::WriteFile(out, "previous");
  const pid_t pid = test::StartCli({"export", big, "--out", out, "--quiet"}, dir_ + "/k.out", dir_ + "/k.err");
  // Killed once its temporary is there (or it finished first).
  auto temporary = [&] {
    for (const auto& e : std::filesystem::directory_iterator(dir_)) {
      if (e.path().filename().string().rfind("killed.h5.tmp-", 0) == 0) return true;
    }
    return false;
  };
  test::WaitUntil([&] { return temporary() || test::ReadFile(out) != "previous"; });
  test::StopProcess(pid, SIGKILL);
  const std::string after = test::ReadFile(out);
  if (after != "previous") {
    EXPECT_EQ(test::H5Groups(out), (std::vector<std::string>{"RL_RAW"}));
    EXPECT_EQ(test::ReadH5Table(out, "RL_RAW")[2].integer.size(), 200000u);
  }
  const bool left_behind = temporary();
  ASSERT_EQ(test::RunCli({"export", big, "--out", out, "--quiet"}).exit_code, 0);
  EXPECT_FALSE(temporary()) << "left behind by the killed export: " << left_behind;
  EXPECT_EQ(test::ReadH5Table(out, "RL_RAW")[2].integer.size(), 200000u);
}

TEST_F(InfoExport, InfoOfAMissingFileNamesIt) {
  const auto r = test::RunCli({"info", dir_ + "/missing.csv"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.csv"), std::string::npos) << r.err;
}

// Oracle: progress.h's contract. With stderr on a pseudo-terminal the bar is
// drawn (its line is cleared at the end with ESC[K); with --quiet nothing
// of it reaches the terminal.
TEST_F(InfoExport, ProgressOnlyOnATerminalWithoutQuiet) {
  for (bool quiet : {false, true}) {
    int master = -1, slave = -1;
    ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    const std::string out = dir_ + (quiet ? "/q.csv" : "/p.csv");
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      dup2(slave, 2);
      const int devnull = open("/dev/null", O_WRONLY);
      dup2(devnull, 1);
      std::vector<const char*> argv = {ROCKLAB_BINARY, "export", log_.c_str(), "--out", out.c_str()};
      if (quiet) argv.push_back("--quiet");
      argv.push_back(nullptr);
      execv(ROCKLAB_BINARY, const_cast<char* const*>(argv.data()));
      _exit(127);
    }
    close(slave);
    std::string text;
    char buf[4096];
    for (;;) {
      pollfd p{master, POLLIN, 0};
      if (poll(&p, 1, 20000) <= 0) break;
      const ssize_t n = read(master, buf, sizeof buf);
      if (n <= 0) break;  // EIO once the child closed the terminal
      text.append(buf, static_cast<std::size_t>(n));
    }
    int status = 0;
    waitpid(pid, &status, 0);
    close(master);
    EXPECT_NE(text.find("rows in"), std::string::npos) << text;  // the summary reached the terminal
    if (quiet) {
      EXPECT_EQ(text.find("\033[K"), std::string::npos) << text;
    } else {
      EXPECT_NE(text.find("\033[K"), std::string::npos) << text;
    }
  }
}


// Oracle: the escape rule of docs/reliability.md: a log whose RL_DAQ_CONFIG
// strings (rig, calibration, channel names and units) hold terminal
// control sequences and bytes that are not UTF-8 prints, in `info`,
// only printable text, those bytes shown as \xNN; `info --json` is valid
// JSON (the bad bytes as U+FFFD) instead of an exception.
TEST(InfoHostile, InfoPrintsALogsStringsEscaped) {
  const std::string dir = test::ScratchDir("info_hostile");
  const std::string log = dir + "/hostile.lcm";
  {
    common::LogWriter w(log);
    rocklab::daq_config2_t c{};
    c.utime = 1'000'000;
    c.rig_name = "rig\x1b]0;pwned\x07";
    c.calibration_id = "cal\x1b[2J\xff";
    c.sample_rate_hz = 1000;
    c.num_channels = 1;
    c.channel_names = {"a\rb"};
    c.channel_units = {"m\x9b"};
    c.channel_sensors = {""};
    c.gain = {1};
    c.offset = {0};
    c.alpha = 0.25;
    c.p = 2.5;
    c.mu = 0.9;
    Put(w, "RL_DAQ_CONFIG", c);
  }
  const auto r = test::RunCli({"info", log});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (unsigned char ch : r.out) EXPECT_TRUE(ch == '\n' || (ch >= 0x20 && ch != 0x7f)) << int(ch) << " in\n" << r.out;
  for (const char* shown : {"rig\\x1b]0;pwned\\x07", "cal\\x1b[2J\\xff", "a\\x0db [m\\x9b]"}) {
    EXPECT_NE(r.out.find(shown), std::string::npos) << shown << " missing in\n" << r.out;
  }
  const auto j = test::RunCli({"info", log, "--json"});
  ASSERT_EQ(j.exit_code, 0) << j.err;
  const auto parsed = nlohmann::json::parse(j.out);
  EXPECT_EQ(parsed.at("config").at("calibration").get<std::string>(), "cal\x1b[2J\xEF\xBF\xBD");
}

}  // namespace
}  // namespace rocklab
