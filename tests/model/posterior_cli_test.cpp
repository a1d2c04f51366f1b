// `rocklab fit --posterior` as a user runs it: the JSON's `posterior`
// object (docs/identification.md), the draws file (CSV header, HDF5), the
// corner plot, the rig's [posterior] priors, and the exit code of a run that
// has not converged. Records from the tests' RK4 reference (fit_synthetic.h).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/test_record.h"
#include "tests/model/fit_synthetic.h"
#include "tests/tools/run_cli.h"
#include "tests/paper_blocks.h"

namespace rocklab::test {
namespace {

using ::rocklab::test::kBlock1;  // tests/paper_blocks.h

std::string PosteriorFreeCsv(const std::string& dir) {
  const std::string path = dir + "/free.csv";
  model::WriteThetaCsv(path, SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 1));
  return path;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// Oracle: the keys docs/identification.md documents, the truth of the
// record (medians within 4 posterior sd, as model_posterior_test), the CSV
// header the band engineer's reader expects, one row per kept draw.
TEST(CliPosterior, JsonKeysSamplesAndPlot) {
  const std::string dir = ScratchDir("posterior_json");
  const CliResult r = RunCli({"fit", "--input", PosteriorFreeCsv(dir), "--width", "0.247", "--height", "1.0", "--posterior",
                              "--seed", "4", "--walkers", "32", "--steps", "4000", "--json", "--quiet", "--samples",
                              dir + "/draws.csv", "--plot", dir + "/corner.svg"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("alpha"));  // the point fit's keys stay
  const auto& p = j.at("posterior");
  const std::vector<std::string> names = {"alpha", "p", "mu", "sigma", "t_offset"};
  EXPECT_EQ(p.at("parameters").get<std::vector<std::string>>(), names);
  const double truth[3] = {kBlock1.alpha, kBlock1.p, kBlock1.mu};
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto& s = p.at(names[i]);
    for (const char* key : {"median", "ci68", "ci95", "sd"}) EXPECT_TRUE(s.contains(key)) << names[i] << " " << key;
    EXPECT_EQ(s.at("ci68").size(), 2u);
    EXPECT_LT(s.at("ci95")[0].get<double>(), s.at("ci68")[0].get<double>());
    EXPECT_GT(s.at("ci95")[1].get<double>(), s.at("ci68")[1].get<double>());
    EXPECT_TRUE(p.at("rhat").contains(names[i]));
    EXPECT_TRUE(p.at("ess").contains(names[i]));
    EXPECT_TRUE(p.at("tau").contains(names[i]));
    if (i < 3) {
      EXPECT_NEAR(s.at("median").get<double>(), truth[i], 4 * s.at("sd").get<double>()) << names[i];
    }
  }
  EXPECT_EQ(p.at("correlation").at("order").get<std::vector<std::string>>(), names);
  EXPECT_EQ(p.at("correlation").at("matrix").size(), 5u);
  for (const char* key : {"acceptance", "walkers", "steps", "seed", "converged", "problems", "burn_in"}) {
    EXPECT_TRUE(p.contains(key)) << key;
  }
  EXPECT_EQ(p.at("walkers"), 32);
  EXPECT_EQ(p.at("steps"), 4000);
  EXPECT_EQ(p.at("seed"), 4);
  EXPECT_TRUE(p.at("converged").get<bool>()) << p.at("problems").dump();
  // alpha and p lie on the ridge of the quarter time (docs/commands.md: -0.99).
  EXPECT_LT(p.at("correlation").at("matrix")[0][1].get<double>(), -0.9);

  const std::vector<std::string> rows = Lines(ReadFile(dir + "/draws.csv"));
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0], "alpha,p,mu,sigma,t_offset,log_posterior");
  EXPECT_EQ(rows.size(), 1u + 32u * 2000u);  // header + walkers x (steps - burn-in)
  const std::string svg = ReadFile(dir + "/corner.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("t_offset"), std::string::npos);
}

// Oracle: the rule of docs/identification.md. 12 steps cannot reach 20
// autocorrelation times: exit code 1 (the work failed, docs/commands.md)
// with a line naming why, the JSON still written; --allow-unconverged: exit 0.
TEST(CliPosterior, UnconvergedRunExitsOne) {
  const std::string dir = ScratchDir("posterior_unconverged");
  const std::string input = PosteriorFreeCsv(dir);
  const std::vector<std::string> args = {"fit", "--input", input, "--width", "0.247", "--height", "1.0",
                                         "--posterior", "--steps", "12", "--quiet", "--out", dir + "/fit.json"};
  const CliResult r = RunCli(args);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("has not converged"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(ReadFile(dir + "/fit.json"));
  EXPECT_FALSE(j.at("posterior").at("converged").get<bool>());
  EXPECT_FALSE(j.at("posterior").at("problems").empty());
  std::vector<std::string> allow = args;
  allow.push_back("--allow-unconverged");
  const CliResult ok = RunCli(allow);
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("NOT converged"), std::string::npos);
}

// The rig's [posterior] section sets the priors (here a narrower p range,
// which the sampled p must respect); a bad key is refused naming file, line
// and key; without geometry --posterior is refused.
TEST(CliPosterior, RigPriorsAndRefusals) {
  const std::string dir = ScratchDir("posterior_rig");
  const std::string input = PosteriorFreeCsv(dir);
  const std::string rig = dir + "/rig.toml";
  {
    std::ofstream f(rig);
    f << "name = \"t\"\nsample_rate_hz = 500.0\n[block]\nwidth_m = 0.247\nheight_m = 1.0\n"
         "[posterior]\np_range = 0.05\nmu_min = 0.5\n[[channel]]\nname = \"acc\"\nsensor = \"table.acceleration\"\n";
  }
  const CliResult r = RunCli({"fit", "--input", input, "--rig", rig, "--posterior", "--steps", "200",
                              "--allow-unconverged", "--quiet", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto p = nlohmann::json::parse(r.out).at("posterior").at("p");
  const double p_geo = 3.7796;  // RectangleBlock(0.247, 1.0).p, docs/commands.md
  EXPECT_GT(p.at("ci95")[0].get<double>(), 0.95 * p_geo - 1e-3);
  EXPECT_LT(p.at("ci95")[1].get<double>(), 1.05 * p_geo + 1e-3);
  {
    std::ofstream f(rig);
    f << "name = \"t\"\nsample_rate_hz = 500.0\n[block]\nwidth_m = 0.247\nheight_m = 1.0\n"
         "[posterior]\np_range = 1.5\n[[channel]]\nname = \"acc\"\nsensor = \"table.acceleration\"\n";
  }
  const CliResult bad = RunCli({"fit", "--input", input, "--rig", rig, "--posterior"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("rig.toml:7: key 'posterior.p_range'"), std::string::npos) << bad.err;
  const CliResult no_geometry = RunCli({"fit", "--input", input, "--posterior"});
  EXPECT_EQ(no_geometry.exit_code, 2);
  EXPECT_NE(no_geometry.err.find("geometry"), std::string::npos) << no_geometry.err;
}

// Per-impact restitution (docs/identification.md): the rig's
// posterior.sigma_mu_max turns it on and bounds sigma_mu's prior; the JSON
// gains `sigma_mu` and `mu_bar` (the same object as `mu`, which stays), the
// draws the column sigma_mu after mu. Oracle: the documented keys and
// header, the prior's support; a bad bound and the trajectory method are
// refused (exit 2) naming the key or option.
TEST(CliPosterior, PerImpactRestitution) {
  const std::string dir = ScratchDir("posterior_per_impact");
  const std::string input = PosteriorFreeCsv(dir);
  const std::string rig = dir + "/rig.toml";
  auto write_rig = [&rig](const std::string& posterior) {
    std::ofstream f(rig);
    f << "name = \"t\"\nsample_rate_hz = 500.0\n[block]\nwidth_m = 0.247\nheight_m = 1.0\n[posterior]\n" << posterior
      << "\n[[channel]]\nname = \"acc\"\nsensor = \"table.acceleration\"\n";
  };
  write_rig("sigma_mu_max = 0.05");
  const CliResult r = RunCli({"fit", "--input", input, "--rig", rig, "--posterior", "--walkers", "16", "--steps", "100",
                              "--allow-unconverged", "--quiet", "--json", "--samples", dir + "/draws.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto p = nlohmann::json::parse(r.out).at("posterior");
  EXPECT_EQ(p.at("parameters").get<std::vector<std::string>>(),
            (std::vector<std::string>{"alpha", "p", "mu", "sigma_mu", "sigma", "t_offset"}));
  EXPECT_EQ(p.at("mu_bar"), p.at("mu"));
  EXPECT_GT(p.at("sigma_mu").at("ci95")[0].get<double>(), 0.0);
  EXPECT_LE(p.at("sigma_mu").at("ci95")[1].get<double>(), 0.05);
  EXPECT_EQ(p.at("units").at("sigma_mu"), "1");
  EXPECT_EQ(Lines(ReadFile(dir + "/draws.csv"))[0], "alpha,p,mu,sigma_mu,sigma,t_offset,log_posterior");
  const CliResult trajectory = RunCli({"fit", "--input", input, "--width", "0.247", "--height", "1.0", "--posterior",
                                       "--per-impact-mu", "--method", "trajectory"});
  EXPECT_EQ(trajectory.exit_code, 2);
  EXPECT_NE(trajectory.err.find("--per-impact-mu"), std::string::npos) << trajectory.err;
  write_rig("sigma_mu_max = 0.7");
  const CliResult bad = RunCli({"fit", "--input", input, "--rig", rig, "--posterior"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("rig.toml:7: key 'posterior.sigma_mu_max'"), std::string::npos) << bad.err;
}

// --samples FILE.h5: the HDF5 table `posterior` (export's H5Writer); its
// signature and that the CSV is not written instead.
TEST(CliPosterior, SamplesAsHdf5) {
  const std::string dir = ScratchDir("posterior_h5");
  const CliResult r = RunCli({"fit", "--input", PosteriorFreeCsv(dir), "--width", "0.247", "--height", "1.0", "--posterior",
                              "--steps", "100", "--allow-unconverged", "--quiet", "--samples", dir + "/draws.h5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string h5 = ReadFile(dir + "/draws.h5");
  ASSERT_GT(h5.size(), 8u);
  EXPECT_EQ(h5.substr(0, 8), std::string("\x89HDF\r\n\x1a\n", 8));
}

}  // namespace
}  // namespace rocklab::test
