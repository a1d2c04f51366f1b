// The monitor page in a real headless Chromium (Debian's, driven by
// playwright-core: tests/monitor/browser/monitor_page.js) during an
// end-to-end replay over UDP multicast inside a private network namespace:
// `rocklab monitor` + `rocklab run` of the bundled figure-7 test of block 1
// with the demo's four variants. Checks that the charts received data and
// that the numbers the page shows for each variant are the comparator's
// (its final RL_COMPARE, which equals the summary JSON the run writes), and
// saves a screenshot: build/test-artifacts/monitor.png. The same with an
// assembly (a statue on its pedestal, synth's record, an assembly variant):
// a chart per body with the measured and the variant's angle, and each
// body's figures and the mode agreement as compare's summary JSON has them
// (build/test-artifacts/monitor_bodies.png).
//
// Which fields match: comparison2_t.rms_total is the summary's "rms",
// .nrms "nrms", .correlation "correlation", .samples "samples" (the final
// RL_COMPARE is published from the same ComparisonMetrics as the summary).
// The page prints them with %.4g, angles in rad (its default unit, as the
// summary's): a shown number must equal the summary's to half a unit in its
// fourth significant digit.
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"
#include "tests/four_digits.h"
#include "tests/skip.h"
#include "tests/source_paths.h"

namespace rocklab::monitor {
namespace {

using nlohmann::json;

using ::rocklab::test::kSource;  // tests/source_paths.h
constexpr const char* kChromium = "/usr/bin/chromium";

// Why the page cannot be tested here, or "" when it can.
std::string CannotRun() {
  if (access(kChromium, X_OK) != 0) {
    return std::string("no ") + kChromium + " (Debian package chromium; tools/test.sh installs it): browser test skipped";
  }
  if (std::system("unshare -n true 2>/dev/null") != 0) {
    return "no private network namespace (needs root): browser test skipped";
  }
  return "";
}

// In a private network namespace: `rocklab monitor` on udpm, the page in
// Chromium (monitor_page.js), then `run_args` (the arguments of `rocklab
// run` after --lcm-url, --summary summary.json) once the page is live,
// after `prepare` (shell lines run first, in `dir`). Leaves result.json
// (what the page showed) and summary.json (compare's) in `dir`.
void RunThePage(const std::string& dir, const std::string& screenshot, const std::string& prepare,
                const std::string& run_args) {
  const std::string binary = ROCKLAB_BINARY;
  const std::string script =
      "set -u\ncd '" + dir + "'\nrm -rf profile ready done result.json summary.json\n" + prepare +
      "ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || exit 77\n"
      "lcm='udpm://239.255.76.67:7667?ttl=0'\n"
      // A 4 MB socket buffer: the run sends ~35 000 messages in under 2 s.
      "'" + binary + "' monitor --lcm-url \"$lcm&recv_buf_size=4194304\" --http 127.0.0.1:0 "
      ">monitor.out 2>monitor.err &\nmon=$!\n"
      "for i in $(seq 200); do grep -q serving monitor.out && break; sleep 0.05; done\n"
      "url=$(sed -n 's/^rocklab monitor: serving //p' monitor.out)\n"
      "[ -n \"$url\" ] || { kill $mon; exit 78; }\n"
      "NODE_PATH='" ROCKLAB_BROWSER_DIR "/node_modules' '" ROCKLAB_NODE "' '" + kSource +
      "/tests/monitor/browser/monitor_page.js' \"$url\" result.json '" + screenshot +
      "' ready done profile >node.out 2>&1 &\nnode=$!\n"
      "for i in $(seq 400); do [ -f ready ] && break; kill -0 $node 2>/dev/null || break; sleep 0.05; done\n"
      "[ -f ready ] || { kill $node; kill $mon; wait; exit 79; }\n"
      "'" + binary + "' run --lcm-url \"$lcm\" --summary summary.json " + run_args +
      " >run.out 2>run.err\nrc_run=$?\ntouch done\n"
      "wait $node\nrc_node=$?\nkill -TERM $mon\nwait $mon\nrc_mon=$?\n"
      "echo \"$rc_run $rc_node $rc_mon\" > codes\n";
  test::WriteFile(dir + "/browser.sh", script);
  const int status = std::system(("unshare -n sh '" + dir + "/browser.sh'").c_str());
  ASSERT_NE(WEXITSTATUS(status), 77) << "cannot set up lo in the namespace";
  ASSERT_NE(WEXITSTATUS(status), 78) << "the monitor printed no URL: " << test::ReadFile(dir + "/monitor.err");
  ASSERT_NE(WEXITSTATUS(status), 79) << "the page never went live: " << test::ReadFile(dir + "/node.out");
  ASSERT_NE(WEXITSTATUS(status), 76) << "preparing the record failed: " << test::ReadFile(dir + "/prepare.err");
  ASSERT_EQ(WEXITSTATUS(status), 0);
  int rc_run = -1, rc_node = -1, rc_mon = -1;
  ASSERT_EQ(std::sscanf(test::ReadFile(dir + "/codes").c_str(), "%d %d %d", &rc_run, &rc_node, &rc_mon), 3);
  ASSERT_EQ(rc_run, 0) << test::ReadFile(dir + "/run.err");
  ASSERT_EQ(rc_node, 0) << test::ReadFile(dir + "/node.out");
  EXPECT_EQ(rc_mon, 0) << "monitor exit on SIGTERM: " << test::ReadFile(dir + "/monitor.err");
}

std::string NewScreenshot(const std::string& name) {
  const std::string artifacts = ROCKLAB_ARTIFACT_DIR;
  std::filesystem::create_directories(artifacts);
  const std::string screenshot = artifacts + "/" + name;
  std::filesystem::remove(screenshot);
  return screenshot;
}

TEST(MonitorBrowser, PageShowsTheReplayAndTheComparatorsNumbers) {
  if (const std::string why = CannotRun(); !why.empty()) ROCKLAB_SKIP(why);
  const std::string dir = test::ScratchDir("monitor_browser");
  const std::string screenshot = NewScreenshot("monitor.png");
  const std::string fitted = "alpha=0.235,p=3.884,mu=0.937";  // Table 2, block 1 (tools/demo.sh)
  RunThePage(dir, screenshot, "",
             "--rig '" + kSource + "/data/rigs/block1_rig.toml' --input '" + kSource +
                 "/data/samples/fig7_block1.csv' --speed 4"
                 " --variant fitted_complex:complex:" + fitted + " --variant fitted_housner:housner:" + fitted +
                 " --variant theory_complex:complex:theoretical --variant theory_housner:housner:theoretical");
  if (HasFatalFailure()) return;

  const json shown = json::parse(test::ReadFile(dir + "/result.json"));
  const json summary = json::parse(test::ReadFile(dir + "/summary.json"));
  EXPECT_EQ(shown.at("mode"), "live");
  EXPECT_TRUE(shown.at("consoleErrors").empty()) << shown.at("consoleErrors").dump(2);
  // The charts received data: theta (x, measured, 4 variants) and the error
  // (x, error and rms of each variant); 7 s at 100 Hz and RL_COMPARE at 20 Hz.
  const json& lengths = shown.at("dataLengths");
  ASSERT_EQ(lengths.at("theta").size(), 6u) << lengths.dump();
  ASSERT_EQ(lengths.at("error").size(), 9u) << lengths.dump();
  for (const json& n : lengths.at("theta")) EXPECT_GT(n.get<int>(), 600) << lengths.dump();
  for (const json& n : lengths.at("error")) EXPECT_GT(n.get<int>(), 100) << lengths.dump();
  // A single block: no body charts, their section hidden.
  EXPECT_TRUE(shown.at("bodyRows").empty()) << shown.at("bodyRows").dump();
  EXPECT_TRUE(shown.at("bodiesHidden").get<bool>());

  ASSERT_EQ(summary.at("variants").size(), 4u);
  const std::map<std::string, std::string> field_of = {
      {"rms_total", "rms"}, {"nrms", "nrms"}, {"correlation", "correlation"}};
  for (const json& v : summary.at("variants")) {
    const std::string name = v.at("name");
    SCOPED_TRACE(name);
    ASSERT_TRUE(shown.at("cells").contains(name)) << shown.at("cells").dump(2);
    const json& cells = shown.at("cells").at(name);
    EXPECT_EQ(cells.at("samples").get<std::string>(), std::to_string(v.at("samples").get<long>()));
    EXPECT_EQ(cells.at("model").get<std::string>(), v.at("model").get<std::string>());
    // The page shows angles in rad by default (rms_total, alpha), as the summary.
    for (const auto& [page_field, summary_field] : field_of) {
      const std::string text = cells.at(page_field);
      const double exact = v.at(summary_field).get<double>();
      EXPECT_TRUE(rocklab::test::SameAtFourDigits(text, exact))
          << page_field << " shown '" << text << "', summary " << summary_field << " " << exact;
    }
    for (const char* param : {"alpha", "p", "mu"}) {
      EXPECT_TRUE(rocklab::test::SameAtFourDigits(cells.at(param), v.at(param).get<double>())) << param;
    }
  }
  // Static mode (the report's): the same numbers and charts from the
  // inlined final snapshot, without a single request.
  const json& still = shown.at("static");
  EXPECT_EQ(still.at("mode"), "static");
  EXPECT_TRUE(still.at("requests").empty()) << still.at("requests").dump(2);
  EXPECT_EQ(still.at("cells"), shown.at("cells"));
  EXPECT_EQ(still.at("dataLengths"), lengths);
  // Every node's health reached the page.
  for (const char* node : {"daq", "model", "compare"}) {
    EXPECT_TRUE(shown.at("health").contains(node)) << node;
  }
  EXPECT_TRUE(std::filesystem::exists(screenshot));
}

// The statue on its pedestal shaken hard (docs/compare.md's record: 2.5 s
// at 1 kHz), run live with the assembly variant "stack" (its model node
// runs the stack, compare pairs every body with RL_BODIES). Oracle: the
// run's --summary JSON, compare's figures per body ("bodies") and its mode
// agreement, which its final RL_COMPAREBODIES carries (the page's newest);
// the page prints them with %.4g (the default unit, rad, as the JSON's).
TEST(MonitorBrowser, AnAssemblyGetsAChartAndFiguresPerBody) {
  if (const std::string why = CannotRun(); !why.empty()) ROCKLAB_SKIP(why);
  const std::string dir = test::ScratchDir("monitor_browser_bodies");
  const std::string screenshot = NewScreenshot("monitor_bodies.png");
  const std::string rig = kSource + "/data/rigs/statue_rig.toml";
  const std::string assembly = kSource + "/data/assemblies/statue_on_pedestal.toml";
  RunThePage(dir, screenshot,
             "'" + std::string(ROCKLAB_BINARY) + "' synth --rig '" + rig + "' --assembly '" + assembly +
                 "' --excitation sine:amp=0.007,freq=8,duration=1,start=0.2 --duration 2.5 --rate 1000"
                 " --seed 3 --out raw.csv --truth truth.csv >prepare.out 2>prepare.err || exit 76\n",
             "--rig '" + rig + "' --input raw.csv --speed 2 --variant 'stack:housner:" + assembly + "'");
  if (HasFatalFailure()) return;

  const json shown = json::parse(test::ReadFile(dir + "/result.json"));
  const json summary = json::parse(test::ReadFile(dir + "/summary.json"));
  EXPECT_EQ(shown.at("mode"), "live");
  EXPECT_TRUE(shown.at("consoleErrors").empty()) << shown.at("consoleErrors").dump(2);
  ASSERT_EQ(summary.at("variants").size(), 1u);
  const json& stack = summary.at("variants").at(0);
  ASSERT_EQ(stack.at("bodies").size(), 2u);

  // One chart per body, bottom-up, each with the measured angle (RL_BODIES)
  // and the variant's: 2.5 s at 100 points a second per series.
  EXPECT_FALSE(shown.at("bodiesHidden").get<bool>());
  const json& rows = shown.at("bodyRows");
  ASSERT_EQ(rows.size(), 2u) << rows.dump(2);
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE("body " + std::to_string(k));
    const json& row = rows.at(k);
    EXPECT_EQ(row.at("body").get<int>(), k);
    EXPECT_NE(row.at("title").get<std::string>().find("body " + std::to_string(k)), std::string::npos) << row;
    EXPECT_EQ(row.at("series"), json::array({"measured", "stack"})) << row;
    ASSERT_EQ(row.at("points").size(), 3u) << row;  // x, measured, stack
    for (const json& n : row.at("points")) EXPECT_GT(n.get<int>(), 200) << row;
  }
  // Each body's figures, by index, as compare's summary has them.
  const std::map<std::string, std::string> field_of = {
      {"rms_total", "rms"}, {"nrms", "nrms"}, {"correlation", "correlation"}};
  for (const json& b : stack.at("bodies")) {
    const std::string k = std::to_string(b.at("body").get<int>());
    SCOPED_TRACE("body " + k);
    ASSERT_TRUE(shown.at("bodyCells").contains("stack")) << shown.at("bodyCells").dump(2);
    const json& cells = shown.at("bodyCells").at("stack").at(k);
    EXPECT_EQ(cells.at("samples").get<std::string>().substr(0, std::to_string(b.at("samples").get<long>()).size()),
              std::to_string(b.at("samples").get<long>()));
    for (const auto& [page_field, summary_field] : field_of) {
      const std::string text = cells.at(page_field);
      const double exact = b.at(summary_field).get<double>();
      EXPECT_TRUE(rocklab::test::SameAtFourDigits(text, exact))
          << page_field << " shown '" << text << "', summary " << summary_field << " " << exact;
    }
  }
  const json& modes = shown.at("modeCells").at("stack");
  EXPECT_EQ(modes.at("mode_samples").get<std::string>(), std::to_string(stack.at("mode_samples").get<long>()));
  EXPECT_TRUE(rocklab::test::SameAtFourDigits(modes.at("mode_agreement"), stack.at("mode_agreement").get<double>()))
      << "shown " << modes.at("mode_agreement") << ", summary " << stack.at("mode_agreement");
  EXPECT_TRUE(rocklab::test::SameAtFourDigits(modes.at("mode_rest_rad"), stack.at("mode_rest_rad").get<double>()));
  // The variant's own row is body 0 against RL_THETA, as for a single block.
  EXPECT_EQ(shown.at("cells").at("stack").at("samples").get<std::string>(),
            std::to_string(stack.at("samples").get<long>()));

  // Static mode (the report's page): the same charts and figures.
  const json& still = shown.at("static");
  EXPECT_TRUE(still.at("requests").empty()) << still.at("requests").dump(2);
  EXPECT_EQ(still.at("bodyCells"), shown.at("bodyCells"));
  EXPECT_EQ(still.at("modeCells"), shown.at("modeCells"));
  EXPECT_EQ(still.at("bodyRows"), rows);
  EXPECT_TRUE(std::filesystem::exists(screenshot));
}

}  // namespace
}  // namespace rocklab::monitor
