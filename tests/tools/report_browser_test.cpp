// A `rocklab report` page in a real headless Chromium (Debian's, driven by
// playwright-core: tests/tools/report_page.js), opened from disk with every
// network request refused: the page is self-contained and draws the record.
// Oracles: the snapshot inlined in the page (its series lengths, variants
// and their final sample counts), the log's messages exported by `rocklab
// export` (every sample: the peaks and the impact timings), and the absence
// of any request. The page is laid out in a 1280 px window. Saves a
// screenshot at that width: build/test-artifacts/report.png.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"
#include "tests/four_digits.h"
#include "tests/skip.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using nlohmann::json;

using ::rocklab::test::kSource;  // tests/source_paths.h
constexpr const char* kChromium = "/usr/bin/chromium";
constexpr double kDegPerRadTest = 180.0 / 3.14159265358979323846;

// Significant digits written in a number's text ("0.001234" -> 4, "1.2e-05" -> 2).
int SignificantDigits(const std::string& text) {
  std::string mantissa = text.substr(0, text.find_first_of("eE"));
  int digits = 0;
  bool leading = true;
  for (char c : mantissa) {
    if (c < '0' || c > '9') continue;
    if (leading && c == '0') continue;
    leading = false;
    ++digits;
  }
  return digits;
}

// A numeric column of a CSV written by `rocklab export` (header on line 1).
std::vector<double> CsvColumn(const std::string& path, const std::string& name) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::istringstream head(line);
  int index = -1;
  int i = 0;
  for (std::string field; std::getline(head, field, ','); ++i) {
    if (field == name) index = i;
  }
  std::vector<double> out;
  if (index < 0) return out;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string field;
    for (int k = 0; k <= index; ++k) std::getline(row, field, ',');
    out.push_back(std::strtod(field.c_str(), nullptr));
  }
  return out;
}

double MaxAbs(const std::vector<double>& x) {
  double m = 0;
  for (double v : x) {
    if (std::isfinite(v)) m = std::fmax(m, std::fabs(v));
  }
  return m;
}

TEST(ReportBrowser, PageDrawsTheRecordFromDiskWithNoRequest) {
  if (access(kChromium, X_OK) != 0) {
    ROCKLAB_SKIP(std::string("no ") + kChromium +
                 " (Debian package chromium; tools/test.sh installs it): browser test skipped");
  }
  const std::string dir = test::ScratchDir("report_browser");
  const std::string log = dir + "/fig7.lcm";
  const test::CliResult run = test::RunCli(
      {"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
       kSource + "/data/samples/fig7_block1.csv", "--max", "--variant",
       "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--variant", "theory:housner:theoretical",
       "--log", log});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string html = dir + "/report.html";
  const test::CliResult report = test::RunCli({"report", log, "--out", html});
  ASSERT_EQ(report.exit_code, 0) << report.err;

  const std::string artifacts = ROCKLAB_ARTIFACT_DIR;
  std::filesystem::create_directories(artifacts);
  const std::string screenshot = artifacts + "/report.png";
  std::filesystem::remove(screenshot);
  const std::string command = "NODE_PATH='" ROCKLAB_BROWSER_DIR "/node_modules' '" ROCKLAB_NODE
                              "' '" + kSource + "/tests/tools/report_page.js' '" + html + "' '" +
                              dir + "/shown.json' '" + screenshot + "' >'" + dir +
                              "/node.out' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << test::ReadFile(dir + "/node.out");

  const json shown = json::parse(test::ReadFile(dir + "/shown.json"));
  EXPECT_EQ(shown.at("mode"), "static");
  EXPECT_TRUE(shown.at("requests").empty()) << shown.at("requests").dump(2);
  EXPECT_TRUE(shown.at("consoleErrors").empty()) << shown.at("consoleErrors").dump(2);
  EXPECT_EQ(shown.at("title"), "rocklab report: fig7.lcm");
  // No band in this log: the page draws none, and nothing else on the theta
  // chart has the band's colour (the oracle of the band test below).
  EXPECT_TRUE(shown.at("bandNames").empty());
  EXPECT_EQ(shown.at("bandPixels"), 0);

  // The theta chart holds the time axis, the measured series and one per
  // variant, over the snapshot's points (the model and measured samples
  // share the sample clock, so the axis is the measured series' times).
  const std::string page = test::ReadFile(html);
  const std::string head = "window.ROCKLAB_SNAPSHOT = ";
  const std::size_t at = page.find(head);
  ASSERT_NE(at, std::string::npos);
  const json snap = json::parse(page.substr(at + head.size(), page.find(";</script>", at) - at - head.size()));
  const json& theta = shown.at("dataLengths").at("theta");
  ASSERT_EQ(theta.size(), 2 + snap.at("variants").size()) << theta.dump();
  std::set<double> times;
  for (const json& t : snap.at("measured").at("t")) times.insert(t.get<double>());
  for (const json& v : snap.at("variants")) {
    for (const json& t : v.at("theta").at("t")) times.insert(t.get<double>());
  }
  for (const json& n : theta) EXPECT_EQ(n.get<std::size_t>(), times.size()) << theta.dump();

  // The comparison table shows every variant with its final sample count.
  for (const json& v : snap.at("variants")) {
    const std::string name = v.at("name");
    ASSERT_TRUE(shown.at("cells").contains(name)) << shown.at("cells").dump(2);
    EXPECT_EQ(shown.at("cells").at(name).at("samples").get<std::string>(),
              std::to_string(v.at("latest").at("samples").get<long>()));
    EXPECT_EQ(shown.at("cells").at(name).at("model").get<std::string>(),
              v.at("model").get<std::string>());
  }
  // Radians by default, as the CLI and its files: no header gives an angle
  // in deg; every angle label follows the switch (deg after it).
  for (const json& h : shown.at("headers")) {
    EXPECT_EQ(h.get<std::string>().find("(deg)"), std::string::npos) << h;
  }
  ASSERT_GE(shown.at("unitHeaders").size(), 6u);
  for (const json& u : shown.at("unitHeaders")) EXPECT_EQ(u, "rad");
  for (const json& u : shown.at("degUnitHeaders")) EXPECT_EQ(u, "deg");

  // The page fits a 1280 px window: no horizontal scroll, every table inside.
  EXPECT_LE(shown.at("pageWidth").get<double>(), 1280.0);
  for (const json& right : shown.at("tableRights")) EXPECT_LE(right.get<double>(), 1280.0);

  // The comparison table: whole-test figures. Oracles: the snapshot's
  // newest RL_COMPARE (totals since the start), and every message of the
  // log as `rocklab export` writes it (peaks of |theta|; the impact timing
  // errors, one per matched crossing: the carried value changing).
  const std::string exported = dir + "/x.csv";
  ASSERT_EQ(test::RunCli({"export", log, "--out", exported, "--quiet"}).exit_code, 0);
  const double peak_measured = MaxAbs(CsvColumn(dir + "/x_RL_THETA.csv", "theta"));
  ASSERT_GT(peak_measured, 0.0);
  for (const json& v : snap.at("variants")) {
    const std::string name = v.at("name");
    SCOPED_TRACE(name);
    const json& cells = shown.at("cells").at(name);
    const json& deg_cells = shown.at("degCells").at(name);
    for (const auto& [field, text] : cells.items()) {
      if (field == "name" || field == "model" || field == "samples" || text == "—") continue;
      EXPECT_LE(SignificantDigits(text.get<std::string>()), 4) << field << " " << text;
    }
    const double rms = v.at("latest").at("rms_total").get<double>();
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("rms_total"), rms)) << cells.at("rms_total");
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(deg_cells.at("rms_total"), rms * kDegPerRadTest));
    const double alpha = v.at("alpha").get<double>();
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("alpha"), alpha)) << cells.at("alpha");
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(deg_cells.at("alpha"), alpha * kDegPerRadTest));
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("nrms"), v.at("latest").at("nrms").get<double>()));
    const double peak_model = MaxAbs(CsvColumn(dir + "/x_RL_MODEL_" + name + ".csv", "theta"));
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("peak_theta"), peak_model)) << cells.at("peak_theta");
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("peak_theta_measured"), peak_measured));
    double last = std::nan(""), sum_sq = 0;
    long crossings = 0;
    for (double x : CsvColumn(dir + "/x_RL_COMPARE_" + name + ".csv", "impact_timing_error")) {
      if (std::isfinite(x) && x != last) {
        ++crossings;
        sum_sq += x * x;
      }
      last = x;
    }
    EXPECT_EQ(cells.at("impact_timings").get<std::string>(), std::to_string(crossings));
    if (crossings > 0) {
      EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("impact_timing_rms"), std::sqrt(sum_sq / crossings)));
    } else {
      EXPECT_EQ(cells.at("impact_timing_rms"), "—");
    }
  }

  // The error chart at the model's rate: the first variant's error at each
  // of its model points, theta_model - theta_measured of the snapshot at
  // that time (the same sample clock), rad; far more points than RL_COMPARE's.
  {
    const json& v0 = snap.at("variants").at(0);
    std::map<double, double> measured_deg;
    for (std::size_t i = 0; i < snap.at("measured").at("t").size(); ++i) {
      measured_deg[snap.at("measured").at("t")[i].get<double>()] =
          snap.at("measured").at("theta_deg")[i].get<double>();
    }
    std::map<double, double> model_deg;
    for (std::size_t i = 0; i < v0.at("theta").at("t").size(); ++i) {
      model_deg[v0.at("theta").at("t")[i].get<double>()] = v0.at("theta").at("theta_deg")[i].get<double>();
    }
    const json& chart = shown.at("errorChart");
    std::size_t drawn = 0;
    for (std::size_t i = 0; i < chart.at("t").size(); ++i) {
      if (!chart.at("first")[i].is_number()) continue;
      ++drawn;
      const double t = chart.at("t")[i].get<double>();
      ASSERT_TRUE(model_deg.count(t) && measured_deg.count(t)) << t;
      EXPECT_NEAR(chart.at("first")[i].get<double>(), (model_deg[t] - measured_deg[t]) / kDegPerRadTest,
                  1e-12) << t;
    }
    EXPECT_EQ(drawn, model_deg.size());
    EXPECT_GT(drawn, 4 * v0.at("comparison").at("t").size());
  }

  // Event markers: one row per variant's impacts (and one for uplift, rest,
  // overturn); in a row, markers at least 9 px apart, every event drawn or
  // counted as left out (too close, or past the plotted time range: an
  // event after the last sample). Oracle: the snapshot's events.
  {
    std::map<std::string, std::size_t> expected;  // row -> events
    for (const json& e : snap.at("events")) {
      const std::string kind = e.at("kind");
      if (kind == "impact") ++expected["impact " + e.at("source").get<std::string>()];
      if (kind == "uplift" || kind == "rest" || kind == "overturn") ++expected["uplift/rest/overturn"];
    }
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(shown.at("markers").size(), expected.size()) << shown.at("markers").dump();
    for (const json& row : shown.at("markers")) {
      const std::string name = row.at("row");
      const json& x = row.at("drawn");
      EXPECT_EQ(x.size() + row.at("hidden").get<std::size_t>() + row.at("outside").get<std::size_t>(),
                expected[name]) << name;
      EXPECT_FALSE(x.empty()) << name;
      for (std::size_t i = 1; i < x.size(); ++i) {
        EXPECT_GE(x[i].get<double>() - x[i - 1].get<double>(), 9.0 - 1e-9) << name << " marker " << i;
      }
    }
  }

  // A finished test's health: final counts and the rates over the time each
  // node ran (count / (its last sample clock - the record's start)), not the
  // last instantaneous rate. Oracle: the snapshot's last RL_HEALTH.
  ASSERT_FALSE(snap.at("health").empty());
  for (const json& h : snap.at("health")) {
    const std::string node = h.at("node");
    SCOPED_TRACE(node);
    const json& cells = shown.at("health").at(node);
    EXPECT_EQ(cells.at("count_in").get<std::string>(), std::to_string(h.at("count_in").get<long>()));
    EXPECT_EQ(cells.at("state"), h.at("state"));
    const double ran_s = (h.at("utime").get<double>() - snap.at("t0_utime").get<double>()) / 1e6;
    ASSERT_GT(ran_s, 0.0);
    EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("mean_rate_in_hz"), h.at("count_in").get<double>() / ran_s))
        << cells.at("mean_rate_in_hz");
    EXPECT_FALSE(cells.contains("rate_in_hz"));  // the live figure, 0 Hz once stopped
  }

  // The "series as CSV" button: a file built in the page from the inlined
  // data (no request, checked above), one row per time of the union of the
  // series, the measured theta at its times as the snapshot holds it.
  // Oracle: the snapshot inlined in the same page.
  EXPECT_EQ(shown.at("csvName"), "fig7_series.csv");
  std::istringstream csv(shown.at("csv").get<std::string>());
  std::string header;
  std::getline(csv, header);
  std::string expected_header = "t_s,theta_measured_deg,table_accel_mps2";
  for (const json& v : snap.at("variants")) {
    const std::string name = v.at("name");
    expected_header += ",theta_" + name + "_deg,error_" + name + "_deg,rms_window_" + name + "_deg";
  }
  EXPECT_EQ(header, expected_header);
  std::map<double, double> measured;  // t -> theta_deg
  for (std::size_t i = 0; i < snap.at("measured").at("t").size(); ++i) {
    measured[snap.at("measured").at("t")[i].get<double>()] =
        snap.at("measured").at("theta_deg")[i].get<double>();
  }
  std::size_t rows = 0, measured_rows = 0;
  for (std::string line; std::getline(csv, line);) {
    ++rows;
    const std::size_t comma = line.find(',');
    const std::size_t next = line.find(',', comma + 1);
    const double t = std::stod(line.substr(0, comma));
    const std::string theta_cell = line.substr(comma + 1, next - comma - 1);
    const auto it = measured.find(t);
    if (it == measured.end()) continue;
    ++measured_rows;
    ASSERT_FALSE(theta_cell.empty()) << line;
    EXPECT_DOUBLE_EQ(std::stod(theta_cell), it->second) << line;
  }
  EXPECT_GE(rows, times.size());  // the theta times and the comparison's
  EXPECT_EQ(measured_rows, measured.size());
  EXPECT_TRUE(std::filesystem::exists(screenshot));
}

// The posterior band on the report page: a log of `rocklab run --max` with
// 8 posterior draws of the complex model. Oracles: the snapshot inlined in
// the page (its band's points), the log's last RL_COVERAGE (as the summary
// JSON states it), and the pixels: the band's fill covers part of the theta
// chart, where the page without a band (test above) has none.
TEST(ReportBrowser, PageDrawsThePosteriorBand) {
  if (access(kChromium, X_OK) != 0) {
    ROCKLAB_SKIP(std::string("no ") + kChromium +
                 " (Debian package chromium; tools/test.sh installs it): browser test skipped");
  }
  const std::string dir = test::ScratchDir("report_browser_band");
  const std::string log = dir + "/band.lcm";
  const test::CliResult run = test::RunCli(
      {"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
       kSource + "/data/samples/fig7_block1.csv", "--max", "--quiet", "--variant",
       "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--posterior-samples",
       kSource + "/data/samples/fig7_block1.posterior.csv", "--ensemble", "8", "--log", log,
       "--summary", dir + "/summary.json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string html = dir + "/report.html";
  ASSERT_EQ(test::RunCli({"report", log, "--out", html}).exit_code, 0);
  const std::string command = "NODE_PATH='" ROCKLAB_BROWSER_DIR "/node_modules' '" ROCKLAB_NODE
                              "' '" + kSource + "/tests/tools/report_page.js' '" + html + "' '" +
                              dir + "/shown.json' '" + dir + "/band.png' >'" + dir +
                              "/node.out' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << test::ReadFile(dir + "/node.out");
  const json shown = json::parse(test::ReadFile(dir + "/shown.json"));
  EXPECT_TRUE(shown.at("consoleErrors").empty()) << shown.at("consoleErrors").dump(2);
  ASSERT_EQ(shown.at("bandNames"), json::array({"posterior"}));
  // x, measured, the variant, the band's median and four quantiles.
  EXPECT_EQ(shown.at("dataLengths").at("theta").size(), 8u) << shown.at("dataLengths").dump();
  EXPECT_GT(shown.at("bandPixels").get<int>(), 1000);
  const json summary = json::parse(test::ReadFile(dir + "/summary.json"));
  const json& cells = shown.at("bandCells").at("posterior");
  EXPECT_EQ(cells.at("members").get<std::string>(), "8/8");
  EXPECT_EQ(cells.at("model").get<std::string>(), "complex");
  // The page prints %.4g of the last RL_COVERAGE, which holds the summary's value.
  const double coverage = summary.at("bands").at(0).at("band_coverage_95").get<double>();
  EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at("coverage95_total"), coverage)) << cells.at("coverage95_total");
}

}  // namespace
}  // namespace rocklab::tools
