// `rocklab report` through the binary, on a log made by `rocklab run --log`
// from the bundled figure-7 test (7 s at 1 kHz, two variants).
// Oracles: the log itself, read here event by event (the measured and model
// theta at each sample time, the rig and calibration of RL_DAQ_CONFIG, the
// parameters of each RL_MODEL_ variant, the last nrms of each RL_COMPARE_,
// the table peaks of RL_TABLE); the degree (180/pi per rad); the SVG read
// back with an XML parser; the PNG format's signature and IHDR size.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "tests/tools/lcm_messages.h"
#include "rocklab/table_state_t.hpp"
#include "tests/tools/figure_probe.h"
#include "tests/tools/run_cli.h"
#include "tests/sha256sum.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using nlohmann::json;

using ::rocklab::test::kSource;  // tests/source_paths.h
constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

// The log of one `rocklab run` of the bundled figure-7 test, made once per
// test process.
const std::string& Fig7Log() {
  static const std::string path = [] {
    const std::string log = test::ScratchDir("report_log") + "/fig7.lcm";
    const test::CliResult r = test::RunCli(
        {"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
         kSource + "/data/samples/fig7_block1.csv", "--max", "--variant",
         "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--variant",
         "theory:housner:theoretical", "--log", log});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return log;
  }();
  return path;
}

// What the caption must say, read from the log here.
struct LogFacts {
  std::map<std::int64_t, double> theta;                          // utime -> rad
  std::map<std::string, std::map<std::int64_t, double>> models;  // name -> utime -> rad
  std::map<std::string, rocklab::model_state3_t> last_model;
  std::map<std::string, double> last_nrms;
  std::map<std::string, bool> matched;  // the last RL_COMPARE's timing error is a number
  std::string rig, calibration;
  double peak_accel{}, peak_disp{};
};

LogFacts ReadLog(const std::string& path) {
  LogFacts f;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  rocklab::block_state_t theta{};
  rocklab::model_state3_t model{};
  rocklab::comparison2_t compare{};
  rocklab::daq_config2_t config{};
  rocklab::table_state_t table{};
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    const std::string& channel = ev->channel;
    if (channel == "RL_THETA") {
      EXPECT_GE(theta.decode(ev->data, 0, ev->datalen), 0);
      f.theta[theta.utime] = theta.theta;
    } else if (channel.rfind("RL_MODEL_", 0) == 0) {
      EXPECT_GE(model.decode(ev->data, 0, ev->datalen), 0);
      f.models[channel.substr(9)][model.utime] = model.theta;
      f.last_model[channel.substr(9)] = model;
    } else if (channel.rfind("RL_COMPARE_", 0) == 0) {
      EXPECT_GE(compare.decode(ev->data, 0, ev->datalen), 0);
      f.last_nrms[channel.substr(11)] = compare.nrms;
      f.matched[channel.substr(11)] = std::isfinite(compare.impact_timing_error);
    } else if (channel == "RL_DAQ_CONFIG" && f.rig.empty()) {
      EXPECT_GE(config.decode(ev->data, 0, ev->datalen), 0);
      f.rig = config.rig_name;
      f.calibration = config.calibration_id;
    } else if (channel == "RL_TABLE") {
      EXPECT_GE(table.decode(ev->data, 0, ev->datalen), 0);
      f.peak_accel = std::fmax(f.peak_accel, std::fabs(table.acceleration));
      f.peak_disp = std::fmax(f.peak_disp, std::fabs(table.displacement));
    }
  }
  return f;
}

std::string Printf(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// The JSON the page assigns to window.ROCKLAB_SNAPSHOT.
json PageSnapshot(const std::string& html) {
  const std::string head = "window.ROCKLAB_SNAPSHOT = ";
  const std::size_t at = html.find(head);
  if (at == std::string::npos) return json();
  const std::size_t end = html.find(";</script>", at);
  if (end == std::string::npos) return json();
  return json::parse(html.substr(at + head.size(), end - at - head.size()));
}

// Each point of a snapshot series is the logged sample of the same time, in
// degrees. The time is the sample clock relative to t0_utime (us resolution);
// the value is the same double up to the conversion's rounding (4 ulp).
void ExpectSeriesMatchesLog(const json& series, const std::map<std::int64_t, double>& logged,
                            std::int64_t t0_utime, const std::string& what) {
  const json& t = series.at("t");
  const json& deg = series.at("theta_deg");
  ASSERT_EQ(t.size(), deg.size()) << what;
  int mismatches = 0;
  for (std::size_t i = 0; i < t.size() && mismatches < 5; ++i) {
    const std::int64_t utime = t0_utime + std::llround(t[i].get<double>() * 1e6);
    const auto it = logged.find(utime);
    if (it == logged.end()) {
      ADD_FAILURE() << what << ": point " << i << " at t " << t[i] << " is no logged sample";
      ++mismatches;
      continue;
    }
    EXPECT_DOUBLE_EQ(deg[i].get<double>(), it->second * kDegPerRad) << what << " at t " << t[i];
  }
}

class RocklabReport : public ::testing::Test {
 protected:
  // A folder per test: one test's page must not be taken for another's
  // (BadInputs checks that no page appears) when the group runs in one process.
  void SetUp() override {
    dir_ = test::ScratchDir(std::string("report-") +
                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  std::string dir_;
};

TEST_F(RocklabReport, PageIsSelfContainedAndHoldsTheRecordAsTheLogHasIt) {
  const std::string html_path = dir_ + "/report.html";
  const test::CliResult r = test::RunCli({"report", Fig7Log(), "--out", html_path});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = test::ReadFile(html_path);

  // Self-contained: no element refers to a file or a server (a data: URL
  // is inline), and no src or href anywhere names http(s) or a
  // scheme-relative address. (tests/tools/report_browser_test.cpp opens the
  // page with every request refused.)
  const std::regex fetches(R"re(<(script|link|img|iframe)\b[^>]*\b(src|href)\s*=\s*"(?!data:))re",
                           std::regex::icase);
  EXPECT_FALSE(std::regex_search(html, fetches));
  EXPECT_FALSE(std::regex_search(html, std::regex(R"((src|href)\s*=\s*["']?\s*(https?:)?//)",
                                                  std::regex::icase)));
  EXPECT_EQ(html.find("<script src"), std::string::npos);

  const json snap = PageSnapshot(html);
  ASSERT_TRUE(snap.is_object()) << "no window.ROCKLAB_SNAPSHOT in the page";
  const LogFacts log = ReadLog(Fig7Log());
  const std::int64_t t0 = snap.at("t0_utime").get<std::int64_t>();
  EXPECT_EQ(t0, log.theta.begin()->first);  // t = 0 is the record's first sample

  // The whole record, decimated to series_rate_hz: 7 s at 100 Hz.
  const json& measured = snap.at("measured");
  const double span_s = static_cast<double>(log.theta.rbegin()->first - t0) * 1e-6;
  const double rate = snap.at("series_rate_hz").get<double>();
  EXPECT_LE(measured.at("t").size(), static_cast<std::size_t>(span_s * rate) + 2);
  EXPECT_GE(measured.at("t").size(), static_cast<std::size_t>(0.98 * span_s * rate));
  ExpectSeriesMatchesLog(measured, log.theta, t0, "measured");

  // One series per RL_MODEL_ variant of the log, each as the log has it.
  std::set<std::string> names;
  for (const json& v : snap.at("variants")) {
    const std::string name = v.at("name").get<std::string>();
    names.insert(name);
    ASSERT_TRUE(log.models.count(name)) << name;
    EXPECT_FALSE(v.at("theta").at("t").empty()) << name;
    ExpectSeriesMatchesLog(v.at("theta"), log.models.at(name), t0, name);
  }
  EXPECT_EQ(names, (std::set<std::string>{"fitted", "theory"}));

  // Its foot says what made it: the log with its size and SHA-256
  // (oracle: coreutils' sha256sum), the command and rocklab's version.
  const std::string hash = test::Sha256sum(Fig7Log());
  ASSERT_EQ(hash.size(), 64u);
  const std::size_t foot = html.find("<footer class=\"provenance\"");
  ASSERT_NE(foot, std::string::npos);
  const std::string tail = html.substr(foot);
  EXPECT_NE(tail.find(Fig7Log() + " (" + std::to_string(std::filesystem::file_size(Fig7Log())) +
                      " bytes, sha256 " + hash + ")"),
            std::string::npos);
  EXPECT_NE(tail.find("report " + Fig7Log() + " --out " + html_path), std::string::npos);
  EXPECT_NE(tail.find("<dt>rocklab_version</dt>"), std::string::npos);
}

TEST_F(RocklabReport, SvgFigureHasOneCurvePerSeriesAndTheLogsParameters) {
  const std::string svg_path = dir_ + "/fig.svg";
  const std::string html_path = dir_ + "/report.html";
  const test::CliResult r =
      test::RunCli({"report", Fig7Log(), "--out", html_path, "--svg", svg_path});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string svg_text = test::ReadFile(svg_path);
  const test::SvgProbe svg = test::ProbeSvg(svg_text);
  ASSERT_TRUE(svg.well_formed) << svg.error;
  EXPECT_EQ(svg.width, 1000);  // the default --size
  // What made it, in its <metadata>: the log with its size and SHA-256
  // (oracle: coreutils' sha256sum).
  const std::string hash = test::Sha256sum(Fig7Log());
  ASSERT_EQ(hash.size(), 64u);
  EXPECT_NE(svg_text.find("key=\"source_1\">" + Fig7Log() + " (" +
                          std::to_string(std::filesystem::file_size(Fig7Log())) + " bytes, sha256 " + hash +
                          ")</rocklab:provenance>"),
            std::string::npos);
  EXPECT_LT(svg_text.find("<metadata>"), svg_text.find("<rocklab:provenance"));
  EXPECT_EQ(svg.height, 650);

  // One curve per series of the snapshot, each with all of its points (and
  // the two of its legend sample).
  const json snap = PageSnapshot(test::ReadFile(html_path));
  ASSERT_EQ(svg.curves.size(), 4u);
  EXPECT_EQ(svg.curves[0].title, "experiment");
  EXPECT_EQ(svg.curves[0].vertices, static_cast<int>(snap.at("measured").at("t").size()) + 2);
  EXPECT_EQ(svg.curves[1].title, "fitted (complex formulation)");
  EXPECT_EQ(svg.curves[2].title, "theory (Housner model)");
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(svg.curves[1 + i].vertices,
              static_cast<int>(snap.at("variants")[i].at("theta").at("t").size()) + 2);
  }
  // The panel under theta: the table acceleration, every point of its series.
  EXPECT_EQ(svg.curves[3].title, "table acceleration (RL_TABLE)");
  EXPECT_EQ(svg.curves[3].vertices, static_cast<int>(snap.at("table").at("t").size()) + 2);
  EXPECT_NE(std::find(svg.texts.begin(), svg.texts.end(), "table accel. (m/s^2)"), svg.texts.end());

  // The caption, line for line, from the log's own messages.
  const LogFacts log = ReadLog(Fig7Log());
  const rocklab::model_state3_t& fitted = log.last_model.at("fitted");
  const rocklab::model_state3_t& theory = log.last_model.at("theory");
  const double span_s =
      static_cast<double>(log.theta.rbegin()->first - log.theta.begin()->first) * 1e-6;
  // No crossing matched (RL_COMPARE's timing error NaN) is said, not shown as 0.
  auto matched = [&log](const std::string& name) {
    return log.matched.at(name) ? std::string() : std::string("; no zero crossing matched (no timing or peak error)");
  };
  const std::vector<std::string> expected = {
      "fitted: complex formulation, alpha " + Printf("%.6g", fitted.alpha) + " rad, p " +
          Printf("%.6g", fitted.p) + " rad/s, mu " + Printf("%.6g", fitted.mu) + ", l " +
          Printf("%.6g", fitted.l) + "; nrms " + Printf("%.3g", log.last_nrms.at("fitted")) + matched("fitted"),
      "theory: Housner model, alpha " + Printf("%.6g", theory.alpha) + " rad, p " +
          Printf("%.6g", theory.p) + " rad/s, mu " + Printf("%.6g", theory.mu) + "; nrms " +
          Printf("%.3g", log.last_nrms.at("theory")) + matched("theory"),
      "rig " + log.rig + ", calibration " + log.calibration + "; record " +
          Printf("%.3f", span_s) + " s; peak table acceleration " +
          Printf("%.4g", log.peak_accel) + " m/s^2, peak table displacement " +
          Printf("%.4g", log.peak_disp * 1e3) + " mm"};
  for (const std::string& line : expected) {
    EXPECT_NE(std::find(svg.texts.begin(), svg.texts.end(), line), svg.texts.end())
        << "caption line missing: " << line;
  }
  // The values are the ones the run was given and the rig's (a check of the
  // oracle itself).
  EXPECT_EQ(Printf("%.6g", fitted.alpha), "0.235");
  EXPECT_EQ(log.rig, "lab-table-A-block1");
  EXPECT_EQ(log.calibration, "2026-11-01-A");
}

// --start/--end: the page and the figure hold the window only, on the
// record's time axis. Oracle: the log's own RL_THETA times (1 kHz, kept at
// 100 Hz: the first sample of each 10 ms slot from the record's first
// sample) and its RL_TABLE peaks inside the window.
TEST_F(RocklabReport, StartAndEndZoomOnAWindowOfTheRecord) {
  const std::string html_path = dir_ + "/zoom.html";
  const std::string svg_path = dir_ + "/zoom.svg";
  const test::CliResult r = test::RunCli(
      {"report", Fig7Log(), "--out", html_path, "--svg", svg_path, "--start", "2", "--end", "4"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json snap = PageSnapshot(test::ReadFile(html_path));
  EXPECT_EQ(snap.at("from_s").get<double>(), 2.0);
  EXPECT_EQ(snap.at("to_s").get<double>(), 4.0);

  const LogFacts log = ReadLog(Fig7Log());
  const std::int64_t t0 = snap.at("t0_utime").get<std::int64_t>();  // the record's first sample
  EXPECT_EQ(t0, log.theta.begin()->first);
  std::vector<double> expected;  // first sample of each 10 ms slot in [2 s, 4 s]
  std::int64_t last_slot = -1;
  for (const auto& [utime, theta] : log.theta) {
    const double t = static_cast<double>(utime - t0) * 1e-6;
    const std::int64_t slot = static_cast<std::int64_t>(std::floor((utime - t0) / 10000.0));
    if (t < 2.0 || t > 4.0 || slot == last_slot) continue;
    last_slot = slot;
    expected.push_back(t);
  }
  const json& t = snap.at("measured").at("t");
  ASSERT_EQ(t.size(), expected.size());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i].get<double>(), expected[i], 1e-9) << i;
  for (const json& v : snap.at("variants")) {
    for (const json& x : v.at("theta").at("t")) {
      EXPECT_GE(x.get<double>(), 2.0);
      EXPECT_LE(x.get<double>(), 4.0);
    }
  }
  for (const json& e : snap.at("events")) {
    EXPECT_GE(e.at("t").get<double>(), 2.0) << e;
    EXPECT_LE(e.at("t").get<double>(), 4.0) << e;
  }
  EXPECT_GT(snap.at("counters").at("outside_window").get<std::int64_t>(), 0);

  const test::SvgProbe svg = test::ProbeSvg(test::ReadFile(svg_path));
  ASSERT_TRUE(svg.well_formed) << svg.error;
  const std::string window = "; window " + Printf("%.3f", expected.front()) + " s to " +
                             Printf("%.3f", expected.back()) + " s";
  bool captioned = false;
  for (const std::string& text : svg.texts) captioned = captioned || text.find(window) != std::string::npos;
  EXPECT_TRUE(captioned) << "no caption with '" << window << "'";
}

void ExpectInputError(const std::vector<std::string>& args, const std::string& names,
                      const std::string& says, const std::string& html_path);  // below

TEST_F(RocklabReport, AWindowWithoutThetaIsAnInputError) {
  const std::string html = dir_ + "/empty.html";
  ExpectInputError({"report", Fig7Log(), "--out", html, "--start", "100", "--end", "200"}, "fig7.lcm",
                   "no RL_THETA sample between 100 s and 200 s", html);
  const test::CliResult r = test::RunCli({"report", Fig7Log(), "--out", html, "--start", "3", "--end", "2"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--end"), std::string::npos) << r.err;
}

// --max-points: a series longer than N halves its resolution until it fits,
// so it holds between N/2 and N points, in order, from the record's first
// sample to its end (7 s at 100 Hz is 700 points; N = 100).
TEST_F(RocklabReport, MaxPointsBoundsEverySeries) {
  const std::string html_path = dir_ + "/capped.html";
  const test::CliResult r = test::RunCli({"report", Fig7Log(), "--out", html_path, "--max-points", "100"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json snap = PageSnapshot(test::ReadFile(html_path));
  EXPECT_EQ(snap.at("max_points").get<int>(), 100);
  std::vector<const json*> series = {&snap.at("measured"), &snap.at("table")};
  for (const json& v : snap.at("variants")) {
    series.push_back(&v.at("theta"));
    series.push_back(&v.at("comparison"));
  }
  for (const json* s : series) {
    const json& t = s->at("t");
    EXPECT_GE(t.size(), 50u) << s->dump().substr(0, 200);
    EXPECT_LE(t.size(), 100u);
    for (std::size_t i = 1; i < t.size(); ++i) EXPECT_LT(t[i - 1].get<double>(), t[i].get<double>());
  }
  const json& t = snap.at("measured").at("t");
  EXPECT_EQ(t.front().get<double>(), 0.0);
  EXPECT_GT(t.back().get<double>(), 6.8);  // the 7 s record's end, within one coarse slot
}

TEST_F(RocklabReport, PngFigureHasTheSignatureAndTheSizeAsked) {
  const std::string png_path = dir_ + "/fig.png";
  const test::CliResult r = test::RunCli(
      {"report", Fig7Log(), "--out", dir_ + "/report.html", "--png", png_path, "--size", "800x500"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string bytes = test::ReadFile(png_path);
  const test::PngProbe png = test::ProbePng(bytes);
  EXPECT_TRUE(png.signature);
  EXPECT_EQ(png.width, 800);
  EXPECT_EQ(png.height, 500);
  // Its provenance in a tEXt chunk (keyword, NUL, text) before IEND, the
  // last chunk; the log's hash as coreutils' sha256sum gives it.
  const std::string hash = test::Sha256sum(Fig7Log());
  ASSERT_EQ(hash.size(), 64u);
  const std::string text = std::string("tEXtrocklab_source_1") + '\0' + Fig7Log() + " (" +
                           std::to_string(std::filesystem::file_size(Fig7Log())) + " bytes, sha256 " + hash + ")";
  const std::size_t at = bytes.find(text);
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(at, bytes.rfind("IEND"));
  EXPECT_EQ(bytes.rfind("IEND"), bytes.size() - 8);
}

// Writes an LCM log of the given (channel, payload) events.
void WriteLog(const std::string& path,
              const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& events) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good()) << path;
  std::int64_t n = 0;
  for (const auto& [channel, data] : events) {
    lcm::LogEvent ev{};
    ev.eventnum = n;
    ev.timestamp = 1000 * n++;
    ev.channel = channel;
    ev.datalen = static_cast<std::int32_t>(data.size());
    ev.data = const_cast<std::uint8_t*>(data.data());
    ASSERT_EQ(log.writeEvent(&ev), 0);
  }
}

std::vector<std::uint8_t> Theta(std::int64_t utime, double theta) {
  rocklab::block_state_t m{};
  m.utime = utime;
  m.theta = theta;
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// Each error is one line on stderr naming the file, exit code 2 (bad input,
// as every command), and no page is written.
void ExpectInputError(const std::vector<std::string>& args, const std::string& names,
                      const std::string& says, const std::string& html_path) {
  const test::CliResult r = test::RunCli(args);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(html_path)) << html_path;
}

TEST_F(RocklabReport, BadInputsAreOneLineNamingTheFile) {
  const std::string html = dir_ + "/report.html";
  ExpectInputError({"report", dir_ + "/missing.lcm", "--out", html}, "missing.lcm",
                   "cannot read LCM log", html);
  const std::string csv = kSource + "/data/samples/fig7_block1.csv";
  ExpectInputError({"report", csv, "--out", html}, "fig7_block1.csv", "is not an LCM log", html);
  const std::string no_theta = dir_ + "/no_theta.lcm";
  WriteLog(no_theta, {{"RL_HEALTH", {1, 2, 3}}, {"OTHER", {4, 5}}});
  ExpectInputError({"report", no_theta, "--out", html}, "no_theta.lcm", "has no RL_THETA", html);
  const std::string bad_theta = dir_ + "/bad_theta.lcm";
  WriteLog(bad_theta, {{"RL_THETA", {1, 2, 3}}, {"RL_THETA", {4, 5, 6}}});
  ExpectInputError({"report", bad_theta, "--out", html}, "bad_theta.lcm",
                   "none of its 2 RL_THETA messages decodes", html);
  ExpectInputError({"report", Fig7Log(), "--out", dir_ + "/no/such/folder/r.html"},
                   "no/such/folder", "does not exist", html);
  ExpectInputError({"report", Fig7Log(), "--out", html, "--svg", dir_ + "/nope/f.svg"},
                   "nope", "does not exist", html);
  ExpectInputError({"report", Fig7Log(), "--out", html, "--size", "20x20"}, "--size", "200",
                   html);
}

// Messages that do not decode are counted and reported; the rest is reported.
TEST_F(RocklabReport, UndecodableMessagesAreCountedNotFatal) {
  const std::string log = dir_ + "/bad.lcm";
  WriteLog(log, {{"RL_THETA", Theta(0, 0.01)},
                 {"RL_THETA", {0xde, 0xad}},
                 {"RL_THETA", Theta(1000, 0.02)},
                 {"RL_TABLE", {0xbe, 0xef}},
                 {"RL_THETA", Theta(2000, 0.03)}});
  const std::string html = dir_ + "/report.html";
  const test::CliResult r = test::RunCli({"report", log, "--out", html, "--series-rate", "1000"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("5 events, 2 that did not decode"), std::string::npos) << r.err;
  const json snap = PageSnapshot(test::ReadFile(html));
  ASSERT_TRUE(snap.is_object());
  EXPECT_EQ(snap.at("counters").at("decode_errors").at("RL_THETA").get<int>(), 1);
  EXPECT_EQ(snap.at("measured").at("theta_deg").size(), 3u);
}

// Oracle: the channel contract (docs/channels.md). A log recorded before model_state3_t carries
// model_state_t on RL_MODEL_*: the report still shows the variant (its
// theta as the log has it, its parameters in the caption), nothing counted
// as a decode error.
TEST_F(RocklabReport, OldModelStateLogIsStillReported) {
  const std::string log = dir_ + "/old_model.lcm";
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (int k = 0; k < 3; ++k) {
    events.push_back({"RL_THETA", Theta(1000 * k, 0.01 * k)});
    rocklab::model_state_t m = test::OldModel("old", 1000 * k, 0.02 * k);
    std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    events.push_back({"RL_MODEL_old", b});
  }
  WriteLog(log, events);
  const std::string html = dir_ + "/report.html";
  const test::CliResult r = test::RunCli({"report", log, "--out", html, "--series-rate", "1000"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json snap = PageSnapshot(test::ReadFile(html));
  ASSERT_TRUE(snap.is_object());
  ASSERT_EQ(snap.at("variants").size(), 1u);
  const json& v = snap.at("variants")[0];
  EXPECT_EQ(v.at("name"), "old");
  EXPECT_EQ(v.at("alpha").get<double>(), 0.235);
  EXPECT_TRUE(v.at("equations").is_null());
  ASSERT_EQ(v.at("theta").at("theta_deg").size(), 3u);
  EXPECT_NEAR(v.at("theta").at("theta_deg")[2].get<double>(), 0.04 * 180 / M_PI, 1e-9);
  EXPECT_TRUE(snap.at("counters").at("decode_errors").empty() ||
              snap.at("counters").at("decode_errors").value("RL_MODEL_old", 0) == 0);
}

// `--series-rate model` keeps every sample as published: a model at 4 kHz
// (its theta and, through it, the error at the model's points) beside a
// measurement at 1 kHz. Oracle: the counts of messages written; the
// default 100 Hz keeps one point per 10 ms slot of the 20 ms record (2).
TEST_F(RocklabReport, SeriesRateModelKeepsEverySampleAsPublished) {
  const std::string log = dir_ + "/model_rate.lcm";
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (int k = 0; k <= 80; ++k) {  // 0 .. 20 ms
    if (k % 4 == 0) events.push_back({"RL_THETA", Theta(250 * k, 0.001 * k)});
    rocklab::model_state3_t m = test::Model("fast", 250 * k, 0.001 * k);
    std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    events.push_back({"RL_MODEL_fast", b});
  }
  WriteLog(log, events);
  const std::string html = dir_ + "/report.html";
  const test::CliResult r = test::RunCli({"report", log, "--out", html, "--series-rate", "model"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json snap = PageSnapshot(test::ReadFile(html));
  ASSERT_TRUE(snap.is_object());
  EXPECT_EQ(snap.at("measured").at("theta_deg").size(), 21u);
  ASSERT_EQ(snap.at("variants").size(), 1u);
  EXPECT_EQ(snap.at("variants")[0].at("theta").at("theta_deg").size(), 81u);
  const test::CliResult coarse = test::RunCli({"report", log, "--out", html});
  ASSERT_EQ(coarse.exit_code, 0) << coarse.err;
  snap = PageSnapshot(test::ReadFile(html));
  EXPECT_EQ(snap.at("variants")[0].at("theta").at("theta_deg").size(), 3u);  // slots at 0, 10, 20 ms
  const test::CliResult bad = test::RunCli({"report", log, "--out", html, "--series-rate", "fast"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--series-rate: 'fast' is not a number (Hz) or 'model'"), std::string::npos) << bad.err;
}

// Without gnuplot the figure fails with a clear line and exit code 1 (the
// command ran and failed); the page is still written.
TEST_F(RocklabReport, MissingGnuplotIsAClearFailure) {
  const std::string path = std::getenv("PATH") ? std::getenv("PATH") : "";
  setenv("PATH", dir_.c_str(), 1);  // a folder without gnuplot; the binary has an absolute path
  const test::CliResult r = test::RunCli(
      {"report", Fig7Log(), "--out", dir_ + "/report.html", "--svg", dir_ + "/fig.svg"});
  setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("rocklab: cannot draw '" + dir_ + "/fig.svg': gnuplot not found"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("gnuplot-nox"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ + "/report.html"));
}

}  // namespace
}  // namespace rocklab::tools
