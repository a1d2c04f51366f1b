// The posterior band end to end through the binary: `rocklab run --max`
// with an ensemble of posterior draws on the bundled figure-7 test, its log,
// its summary, and `rocklab report` of that log.
// Oracles: the log read here event by event (the band's quantiles ordered,
// the coverage recounted from RL_THETA and RL_BAND_ paired by utime, which
// must equal the summary's and the last RL_COVERAGE_'s); the report's
// snapshot and SVG (expat) against the same log.
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "rocklab/band_comparison_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "tests/tools/figure_probe.h"
#include "tests/tools/run_cli.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using nlohmann::json;

using ::rocklab::test::kSource;  // tests/source_paths.h

struct BandRun {
  std::string dir, log, summary;
  test::CliResult result;
};

// One run per test process: 8 draws of the complex model beside one variant.
const BandRun& TheRun() {
  static const BandRun run = [] {
    BandRun r;
    r.dir = test::ScratchDir("band_run");
    r.log = r.dir + "/fig7.lcm";
    r.summary = r.dir + "/summary.json";
    r.result = test::RunCli({"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
                             kSource + "/data/samples/fig7_block1.csv", "--max", "--quiet", "--variant",
                             "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--posterior-samples",
                             kSource + "/data/samples/fig7_block1.posterior.csv", "--ensemble", "8",
                             "--log", r.log, "--summary", r.summary});
    return r;
  }();
  return run;
}

TEST(BandRun, CoverageInTheSummaryIsRecountedFromTheLog) {
  const BandRun& r = TheRun();
  ASSERT_EQ(r.result.exit_code, 0) << r.result.err;
  EXPECT_NE(r.result.err.find("ensemble posterior: complex, 8 draws of"), std::string::npos) << r.result.err;
  EXPECT_NE(r.result.out.find("cover95%"), std::string::npos) << r.result.out;

  lcm::LogFile log(r.log, "r");
  ASSERT_TRUE(log.good());
  std::map<std::int64_t, rocklab::block_state_t> theta;
  std::map<std::int64_t, rocklab::model_band_t> band;
  rocklab::band_comparison_t last_coverage{};
  int coverages = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == "RL_THETA") {
      rocklab::block_state_t m{};
      ASSERT_GT(m.decode(ev->data, 0, ev->datalen), 0);
      theta[m.utime] = m;
    } else if (ev->channel == "RL_BAND_posterior") {
      rocklab::model_band_t m{};
      ASSERT_GT(m.decode(ev->data, 0, ev->datalen), 0);
      band[m.utime] = m;
    } else if (ev->channel == "RL_COVERAGE_posterior") {
      ASSERT_GT(last_coverage.decode(ev->data, 0, ev->datalen), 0);
      ++coverages;
    }
  }
  ASSERT_GT(band.size(), 6000u);  // one per table sample of the 7 s test
  ASSERT_GT(coverages, 100);      // 20 Hz of 7 s
  std::int64_t valid = 0, in95 = 0, in68 = 0, impacts = 0;
  for (const auto& [utime, b] : band) {
    ASSERT_EQ(b.members, 8);
    ASSERT_EQ(b.draws, 8);
    ASSERT_LE(b.theta_lo95, b.theta_lo68);
    ASSERT_LE(b.theta_lo68, b.theta_median);
    ASSERT_LE(b.theta_median, b.theta_hi68);
    ASSERT_LE(b.theta_hi68, b.theta_hi95);
    impacts += b.impacts_up + b.impacts_down;
    const auto it = theta.find(utime);
    if (it == theta.end() || it->second.flags != 0 || !std::isfinite(it->second.theta)) continue;
    ++valid;
    const double x = it->second.theta;
    in95 += b.theta_lo95 <= x && x <= b.theta_hi95;
    in68 += b.theta_lo68 <= x && x <= b.theta_hi68;
  }
  EXPECT_GT(impacts, 8 * 20);  // the test rocks through ~90 impacts per member

  std::ifstream in(r.summary);
  const json summary = json::parse(in);
  const json& s = summary.at("bands").at(0);
  EXPECT_EQ(s.at("name"), "posterior");
  EXPECT_EQ(s.at("model"), "complex");
  EXPECT_EQ(s.at("valid_samples").get<std::int64_t>(), valid);
  EXPECT_DOUBLE_EQ(s.at("band_coverage_95").get<double>(), static_cast<double>(in95) / valid);
  EXPECT_DOUBLE_EQ(s.at("band_coverage_68").get<double>(), static_cast<double>(in68) / valid);
  EXPECT_DOUBLE_EQ(last_coverage.coverage95_total, static_cast<double>(in95) / valid);
  EXPECT_GT(s.at("matched_crossings").get<std::int64_t>(), 10);
  EXPECT_TRUE(s.at("impact_timing_z_rms").is_number());
  EXPECT_EQ(summary.at("variants").at(0).at("name"), "fitted");  // the point variant beside it
}

TEST(BandRun, ReportDrawsTheBandFromTheLog) {
  const BandRun& r = TheRun();
  ASSERT_EQ(r.result.exit_code, 0) << r.result.err;
  const std::string html = r.dir + "/report.html", svg_path = r.dir + "/report.svg";
  const test::CliResult rep = test::RunCli({"report", r.log, "--out", html, "--svg", svg_path});
  ASSERT_EQ(rep.exit_code, 0) << rep.err;
  const std::string page = test::ReadFile(html);
  const std::size_t at = page.find("window.ROCKLAB_SNAPSHOT = ");
  ASSERT_NE(at, std::string::npos);
  const std::size_t start = at + std::string("window.ROCKLAB_SNAPSHOT = ").size();
  const json snap = json::parse(page.substr(start, page.find(";</script>", start) - start));
  const json& b = snap.at("bands").at(0);
  EXPECT_EQ(b.at("name"), "posterior");
  EXPECT_EQ(b.at("members"), 8);
  const std::size_t points = b.at("band").at("t").size();
  EXPECT_GT(points, 500u);  // 100 points per s of 7 s
  for (const char* q : {"median_deg", "lo68_deg", "hi68_deg", "lo95_deg", "hi95_deg"}) {
    EXPECT_EQ(b.at("band").at(q).size(), points) << q;
  }
  EXPECT_TRUE(b.at("latest").at("coverage95_total").is_number());

  const test::SvgProbe svg = test::ProbeSvg(test::ReadFile(svg_path));
  ASSERT_TRUE(svg.well_formed) << svg.error;
  ASSERT_GE(svg.curves.size(), 5u);
  EXPECT_EQ(svg.curves[0].title, "posterior (complex formulation) 95 %");
  EXPECT_EQ(svg.curves[1].title, "posterior (complex formulation) 68 %");
  EXPECT_EQ(svg.curves[2].title, "posterior (complex formulation) median");
  EXPECT_EQ(svg.curves[2].vertices, static_cast<int>(points) + 2);  // the points and the key's sample
  EXPECT_EQ(svg.curves[3].title, "experiment");
  bool caption = false;
  for (const std::string& t : svg.texts) caption = caption || t.rfind("posterior: posterior predictive band", 0) == 0;
  EXPECT_TRUE(caption);
}

// Oracle: a samples file with a bad field: exit 2, the message names the
// option, the file, the line and the column.
TEST(BandRun, BadSamplesFileIsAUsageErrorNamingLineAndColumn) {
  const std::string path = test::ScratchDir("band_bad") + "/bad.csv";
  test::WriteFile(path, "alpha,p,mu,log_posterior\n0.235,3.884,0.937,-1\n0.235,3.884,oops,-1\n");
  const test::CliResult r = test::RunCli({"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
                                          kSource + "/data/samples/fig7_block1.csv", "--max", "--quiet",
                                          "--posterior-samples", path});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--posterior-samples: " + path + ":3, column 3 (mu)"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace rocklab::tools
