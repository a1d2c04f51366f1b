// rocklab sweep-plot's figures: named by what they show, one per
// meaningful group, titles whole, overturning maps per alpha, fragility
// curves that say when they are weak, with a 95 % band.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "sweep/fragility.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

std::set<std::string> FilesIn(const std::string& dir) {
  std::set<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out.insert(e.path().filename().string());
  return out;
}

// A results CSV written by hand: `blocks` of (alpha, p) with mu 0.9, PGAs
// 0.1..1.0 g, two records; a case overturns when PGA > alpha * 3 g (a
// made-up rule: the figures only need outcomes that overlap a little).
std::string HandResults(const std::vector<std::pair<double, double>>& blocks) {
  std::string text = "record,scale,pga_g,alpha,p,mu,model,peak_theta_over_alpha,overturned\n";
  char buf[200];
  for (const auto& [alpha, p] : blocks) {
    for (const char* record : {"a.csv", "b.csv"}) {
      for (int k = 1; k <= 10; ++k) {
        const double pga = 0.1 * k;
        const bool over = pga > alpha * 3 + (record[0] == 'a' ? 0.05 : -0.05) * p;
        std::snprintf(buf, sizeof buf, "%s,%.1f,%.1f,%g,%g,0.9,housner,%g,%d\n", record, pga, pga, alpha, p,
                      over ? 1.0 : 0.5 * pga, over ? 1 : 0);
        text += buf;
      }
    }
  }
  return text;
}

// Oracle: the list of what a 2-alpha x 4-p sweep should give: a
// spectrum against PGA and a fragility per block, a spectrum against p and
// an overturning map per alpha, fragility.csv and its provenance sidecar
// (docs/provenance.md); nothing numbered.
TEST(SweepFigures, NamedByWhatTheyShowOnePerGroup) {
  const std::string dir = ScratchDir("sweep_figures_names");
  std::vector<std::pair<double, double>> blocks;
  for (double alpha : {0.2, 0.25}) {
    for (double p : {2.0, 2.5, 3.0, 3.5}) blocks.emplace_back(alpha, p);
  }
  WriteFile(dir + "/results.csv", HandResults(blocks));
  const CliResult r = RunCli({"sweep-plot", dir + "/results.csv", "--out-dir", dir + "/figs"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::set<std::string> expected = {"fragility.csv", "fragility.provenance.csv",
                                    "spectrum_vs_p_housner_alpha0.2.svg",
                                    "spectrum_vs_p_housner_alpha0.25.svg", "overturn_map_housner_alpha0.2.svg",
                                    "overturn_map_housner_alpha0.25.svg"};
  for (const char* alpha : {"0.2", "0.25"}) {
    for (const char* p : {"2", "2.5", "3", "3.5"}) {
      expected.insert(std::string("spectrum_vs_pga_housner_alpha") + alpha + "_p" + p + ".svg");
      expected.insert(std::string("fragility_housner_alpha") + alpha + "_p" + p + ".svg");
    }
  }
  EXPECT_EQ(FilesIn(dir + "/figs"), expected);
  EXPECT_NE(r.out.find(std::to_string(expected.size()) + " files"), std::string::npos) << r.out;

  // Two p only: no spectrum against p (two points are no spectrum).
  WriteFile(dir + "/two_p.csv", HandResults({{0.2, 2}, {0.2, 3}}));
  ASSERT_EQ(RunCli({"sweep-plot", dir + "/two_p.csv", "--out-dir", dir + "/two"}).exit_code, 0);
  for (const std::string& f : FilesIn(dir + "/two")) EXPECT_EQ(f.find("spectrum_vs_p_"), std::string::npos) << f;

  // Every title line fits the figure. gnuplot's SVG centres each title
  // line at x (text-anchor middle) in font-size F px; DejaVu Sans (the
  // default sans-serif) averages under 0.62 F per character of these
  // titles, so a line of n characters spans at most 0.62 F n px. Oracle:
  // x - 0.31 F n >= 0 and x + 0.31 F n <= the SVG's width.
  const std::regex title_line(
      "<g transform=\"translate\\(([0-9.]+),([0-9.]+)\\)\"[^>]*font-size=\"([0-9.]+)\"[^>]*"
      "text-anchor=\"middle\">\\s*<text>([^<]*)</text>");
  int lines = 0;
  for (const std::string& f : expected) {
    if (f.size() < 4 || f.substr(f.size() - 4) != ".svg") continue;
    const std::string svg = ReadFile(dir + "/figs/" + f);
    const double width = 900;
    ASSERT_NE(svg.find("width=\"900\""), std::string::npos) << f;
    for (std::sregex_iterator it(svg.begin(), svg.end(), title_line), end; it != end; ++it) {
      const double x = std::stod((*it)[1]), y = std::stod((*it)[2]), font = std::stod((*it)[3]);
      const std::string text = (*it)[4];
      if (y > 60) continue;  // below the title band: axis labels, key
      const double half = 0.31 * font * static_cast<double>(text.size());
      EXPECT_GE(x - half, 0.0) << f << ": title line clipped on the left: " << text;
      EXPECT_LE(x + half, width) << f << ": title line clipped on the right: " << text;
      ++lines;
    }
  }
  EXPECT_GE(lines, static_cast<int>(expected.size()) - 1);  // at least one title line per figure
}

// The case that showed it: 3 overturned of 76 where 1.0 g was the highest PGA
// tried, the median beyond it. The fit is reported with its caveats on
// stdout, in fragility.csv (added columns) and in the figure's title.
TEST(SweepFigures, FragilitySaysWhenItIsWeak) {
  const std::string dir = ScratchDir("sweep_figures_weak");
  std::string text = "record,scale,pga_g,alpha,p,mu,model,peak_theta_over_alpha,overturned\n";
  char buf[160];
  int cases = 0;
  for (int k = 1; k <= 10; ++k) {
    const double pga = 0.1 * k;
    const int trials = k < 10 ? 8 : 4, over = (k == 6 || k == 8 || k == 10) ? 1 : 0;
    for (int t = 0; t < trials; ++t, ++cases) {
      std::snprintf(buf, sizeof buf, "r%d.csv,%.1f,%.1f,0.2,3,0.94,housner,%g,%d\n", t, pga, pga,
                    t < over ? 1.0 : 0.3, t < over ? 1 : 0);
      text += buf;
    }
  }
  ASSERT_EQ(cases, 76);
  WriteFile(dir + "/results.csv", text);
  const CliResult r = RunCli({"sweep-plot", dir + "/results.csv", "--out-dir", dir + "/figs"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* says : {"median above the highest PGA tried (1 g): extrapolated", "only 3 overturned",
                           "median 95 % interval (profile likelihood)"}) {
    EXPECT_NE(r.out.find(says), std::string::npos) << says << " missing in\n" << r.out;
  }
  const std::string csv = ReadFile(dir + "/figs/fragility.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "model,alpha,p,mu,rows,overturned,status,median_pga_g,beta,safe_below_g,overturned_above_g,"
            "pga_min_g,pga_max_g,median_low_g,median_high_g,caveat");
  EXPECT_NE(csv.find(",0.1,1,"), std::string::npos) << csv;  // the PGAs tried
  EXPECT_NE(csv.find("extrapolated"), std::string::npos) << csv;
  const std::string svg = ReadFile(dir + "/figs/fragility_housner_alpha0.2_p3.svg");
  EXPECT_NE(svg.find("Caveat: median above the highest PGA tried"), std::string::npos);
  EXPECT_NE(svg.find("95 % band (profile likelihood)"), std::string::npos);
}

// The band's median interval. Oracle 1: outcomes symmetric in ln x about
// x = 1 (20/100 at 0.5, 50/100 at 1, 80/100 at 2) make the likelihood
// symmetric under ln median -> -ln median, so the interval is too:
// ln(low) = -ln(high), to the grid's step (12 standard errors over 240
// steps: 5 % of one standard error, well under 2 % of the interval's
// width of about 4 standard errors). Oracle 2: with this many cases the
// profile interval is close to the Wald interval ln median +- 1.96 se,
// se from the observed information: within 10 % of its half-width.
TEST(SweepFigures, LikelihoodBandIsSymmetricForSymmetricData) {
  const std::vector<sweep::FragilityPoint> points = {{0.5, 100, 20}, {1.0, 100, 50}, {2.0, 100, 80}};
  const sweep::FragilityFit fit = sweep::FitLognormalFragility(points);
  ASSERT_EQ(fit.status, sweep::FragilityFit::Status::kFitted);
  const sweep::FragilityBand band = sweep::LikelihoodBand(points, fit, {0.5, 1.0, 2.0});
  ASSERT_FALSE(band.median_low_open || band.median_high_open);
  const double lo = std::log(band.median_low), hi = std::log(band.median_high);
  EXPECT_LT(lo, 0);
  EXPECT_GT(hi, 0);
  EXPECT_NEAR(lo + hi, 0.0, 0.02 * (hi - lo));
  // Wald: at a = 0 (median 1), d ln(median) = -da / b, so se(ln median) =
  // se(a) / b, se(a)^2 = 1 / sum w_k (a's information when a = 0 makes
  // the cross term's effect on a vanish by symmetry: sum w u = 0).
  const double b = 1 / fit.beta;
  double info_a = 0;
  for (const auto& p : points) {
    const double eta = b * std::log(p.x);
    const double phi = std::exp(-0.5 * eta * eta) / std::sqrt(2 * M_PI), cdf = sweep::NormalCdf(eta);
    info_a += p.trials * phi * phi / (cdf * (1 - cdf));  // expected information (= observed at the MLE here up to O(1/n))
  }
  const double wald_half = 1.959964 / std::sqrt(info_a) / b;
  EXPECT_NEAR(hi, wald_half, 0.1 * wald_half);
  // Oracle 3: at each x the band is the profile interval of eta(x) = a +
  // b ln x, so close to its Wald interval eta +- 1.96 se(eta), se from the
  // inverse of the expected information (computed here with erfc, not the
  // library's NormalCdf): the band's ends, taken back to eta, within 10 %
  // of the Wald half-width, as the median above.
  const double a = -std::log(fit.median) * b;
  double iaa = 0, iab = 0, ibb = 0;
  const auto cdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  for (const auto& p : points) {
    const double u = std::log(p.x), eta = a + b * u;
    const double phi = std::exp(-0.5 * eta * eta) / std::sqrt(2 * M_PI), c = cdf(eta);
    const double w = p.trials * phi * phi / (c * (1 - c));
    iaa += w;
    iab += w * u;
    ibb += w * u * u;
  }
  const double det = iaa * ibb - iab * iab;
  const auto eta_of = [&cdf](double prob) {  // cdf's inverse by bisection
    double below = -10, above = 10;
    for (int i = 0; i < 200; ++i) (cdf(0.5 * (below + above)) < prob ? below : above) = 0.5 * (below + above);
    return 0.5 * (below + above);
  };
  for (std::size_t k = 0; k < band.x.size(); ++k) {
    const double u = std::log(band.x[k]), eta = a + b * u;
    const double se = std::sqrt((ibb - 2 * u * iab + u * u * iaa) / det);
    const double half = 1.959964 * se;
    EXPECT_NEAR(eta_of(band.p_low[k]), eta - half, 0.1 * half) << "x " << band.x[k];
    EXPECT_NEAR(eta_of(band.p_high[k]), eta + half, 0.1 * half) << "x " << band.x[k];
  }
}

}  // namespace
}  // namespace rocklab::test
