// A `rocklab report` page in a real headless Chromium (Debian's, driven by
// playwright-core: tests/tools/report_page.js), opened from disk with every
// network request refused: the page is self-contained and draws the record.
// Oracles: the snapshot inlined in the page (its series lengths, variants
// and their final sample counts) and the absence of any request. Saves a
// screenshot: build/test-artifacts/report.png.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"
#include "tests/skip.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using nlohmann::json;

using ::rocklab::test::kSource;  // tests/source_paths.h
constexpr const char* kChromium = "/usr/bin/chromium";

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
  // Degrees everywhere: no header of the page's tables gives an angle in
  // rad (p stays rad/s: a frequency, not an angle).
  for (const json& h : shown.at("headers")) {
    EXPECT_EQ(h.get<std::string>().find("(rad)"), std::string::npos) << h;
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
  // The page prints %.6g of the last RL_COVERAGE, which holds the summary's value.
  const double coverage = summary.at("bands").at(0).at("band_coverage_95").get<double>();
  EXPECT_NEAR(std::stod(cells.at("coverage95_total").get<std::string>()), coverage, 1e-6);
}

}  // namespace
}  // namespace rocklab::tools
