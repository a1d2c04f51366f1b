// The monitor page in a real headless Chromium (Debian's, driven by
// playwright-core: tests/monitor/browser/monitor_page.js) during an
// end-to-end replay over UDP multicast inside a private network namespace:
// `rocklab monitor` + `rocklab run` of the bundled figure-7 test of block 1
// with the demo's four variants. Checks that the charts received data and
// that the numbers the page shows for each variant are the comparator's
// (its final RL_COMPARE, which equals the summary JSON the run writes), and
// saves a screenshot: build/test-artifacts/monitor.png.
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

TEST(MonitorBrowser, PageShowsTheReplayAndTheComparatorsNumbers) {
  if (access(kChromium, X_OK) != 0) {
    ROCKLAB_SKIP(std::string("no ") + kChromium +
                 " (Debian package chromium; tools/test.sh installs it): browser test skipped");
  }
  if (std::system("unshare -n true 2>/dev/null") != 0) {
    ROCKLAB_SKIP("no private network namespace (needs root): browser test skipped");
  }
  const std::string dir = test::ScratchDir("monitor_browser");
  const std::string artifacts = ROCKLAB_ARTIFACT_DIR;
  std::filesystem::create_directories(artifacts);
  const std::string screenshot = artifacts + "/monitor.png";
  std::filesystem::remove(screenshot);
  const std::string binary = ROCKLAB_BINARY;
  const std::string fitted = "alpha=0.235,p=3.884,mu=0.937";  // Table 2, block 1 (tools/demo.sh)
  const std::string script =
      "set -u\ncd '" + dir + "'\nrm -rf profile ready done result.json summary.json\n"
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
      "'" + binary + "' run --rig '" + kSource + "/data/rigs/block1_rig.toml' --input '" + kSource +
      "/data/samples/fig7_block1.csv' --lcm-url \"$lcm\" --speed 4 --summary summary.json"
      " --variant fitted_complex:complex:" + fitted + " --variant fitted_housner:housner:" + fitted +
      " --variant theory_complex:complex:theoretical --variant theory_housner:housner:theoretical"
      " >run.out 2>run.err\nrc_run=$?\ntouch done\n"
      "wait $node\nrc_node=$?\nkill -TERM $mon\nwait $mon\nrc_mon=$?\n"
      "echo \"$rc_run $rc_node $rc_mon\" > codes\n";
  test::WriteFile(dir + "/browser.sh", script);
  const int status = std::system(("unshare -n sh '" + dir + "/browser.sh'").c_str());
  ASSERT_NE(WEXITSTATUS(status), 77) << "cannot set up lo in the namespace";
  ASSERT_NE(WEXITSTATUS(status), 78) << "the monitor printed no URL: " << test::ReadFile(dir + "/monitor.err");
  ASSERT_NE(WEXITSTATUS(status), 79) << "the page never went live: " << test::ReadFile(dir + "/node.out");
  ASSERT_EQ(WEXITSTATUS(status), 0);
  int rc_run = -1, rc_node = -1, rc_mon = -1;
  ASSERT_EQ(std::sscanf(test::ReadFile(dir + "/codes").c_str(), "%d %d %d", &rc_run, &rc_node, &rc_mon), 3);
  ASSERT_EQ(rc_run, 0) << test::ReadFile(dir + "/run.err");
  ASSERT_EQ(rc_node, 0) << test::ReadFile(dir + "/node.out");
  EXPECT_EQ(rc_mon, 0) << "monitor exit on SIGTERM: " << test::ReadFile(dir + "/monitor.err");

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

}  // namespace
}  // namespace rocklab::monitor
