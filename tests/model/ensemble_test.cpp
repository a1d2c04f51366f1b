// The posterior ensemble: the samples file, the draws picked, the quantiles,
// and the model node's RL_BAND against the same draws run one by one.
#include "model/ensemble.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "common/direct_bus.h"
#include "model/model_node.h"
#include "rocklab/model_band_t.hpp"
#include "tests/model/node_messages.h"
#include "tests/scratch.h"

namespace rocklab::model {
namespace {

using node_messages::Table;
using node_messages::Theta;

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = test::ScratchDir("ensemble") + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Expects `fn` to throw std::invalid_argument whose message holds every one of `parts`.
template <class Fn>
void ExpectError(Fn fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    for (const std::string& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  }
}

// Oracle: the file as written by hand: columns in any order, extra columns
// read past, comments and blank lines skipped, l taken when present.
TEST(PosteriorSamples, ReadsTheParameterColumnsByName) {
  const std::string path = WriteFile("ok.csv",
                                     "log_posterior,mu,sigma,alpha,p,l\n"
                                     "# a comment\n"
                                     "-1.5,0.93,2e-4,0.23,3.9,1e-12\n"
                                     "\n"
                                     "-2.5,0.94,2e-4,0.24,3.8,2e-12\n");
  const std::vector<PosteriorDraw> d = ReadPosteriorSamples(path);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].params.alpha, 0.23);
  EXPECT_EQ(d[0].params.p, 3.9);
  EXPECT_EQ(d[0].params.mu, 0.93);
  EXPECT_EQ(d[0].l, 1e-12);
  EXPECT_EQ(d[0].line, 3);
  EXPECT_EQ(d[1].params.alpha, 0.24);
  EXPECT_EQ(d[1].line, 5);
  const std::vector<PosteriorDraw> no_l = ReadPosteriorSamples(WriteFile("nol.csv", "alpha,p,mu\n0.2,3,0.9\n"));
  EXPECT_TRUE(std::isnan(no_l.at(0).l));
  EXPECT_EQ(no_l.at(0).sigma, 0.0);
  const std::vector<PosteriorDraw> noisy =
      ReadPosteriorSamples(WriteFile("sigma.csv", "alpha,p,mu,sigma,t_offset\n0.2,3,0.9,2.5e-4,0.01\n"));
  EXPECT_EQ(noisy.at(0).sigma, 2.5e-4);
  const std::string bad_sigma = WriteFile("badsigma.csv", "alpha,p,mu,sigma\n0.2,3,0.9,0\n");
  ExpectError([&] { ReadPosteriorSamples(bad_sigma); }, {bad_sigma + ":2", "sigma must be > 0"});
}

// Oracle: the message names the file, the line and the column of the fault.
TEST(PosteriorSamples, BadInputNamesFileLineAndColumn) {
  const std::string bad_number = WriteFile("bad.csv", "alpha,p,mu,log_posterior\n0.2,3,0.9,-1\n0.2,x3,0.9,-1\n");
  ExpectError([&] { ReadPosteriorSamples(bad_number); }, {bad_number + ":3", "column 2 (p)", "'x3'"});
  const std::string short_row = WriteFile("short.csv", "alpha,p,mu\n0.2,3\n");
  ExpectError([&] { ReadPosteriorSamples(short_row); }, {short_row + ":2", "2 fields", "header has 3"});
  const std::string no_mu = WriteFile("nomu.csv", "alpha,p,log_posterior\n0.2,3,-1\n");
  ExpectError([&] { ReadPosteriorSamples(no_mu); }, {no_mu + ":1", "no column 'mu'"});
  const std::string bad_mu = WriteFile("badmu.csv", "alpha,p,mu\n0.2,3,1.5\n");
  ExpectError([&] { ReadPosteriorSamples(bad_mu); }, {bad_mu + ":2", "mu"});
  const std::string empty = WriteFile("empty.csv", "alpha,p,mu\n");
  ExpectError([&] { ReadPosteriorSamples(empty); }, {empty, "no draw"});
  ExpectError([&] { ReadPosteriorSamples(empty + ".missing"); }, {"cannot read"});
  const std::string twice = WriteFile("twice.csv", "alpha,p,mu,alpha\n0.2,3,0.9,0.2\n");
  ExpectError([&] { ReadPosteriorSamples(twice); }, {twice + ":1", "'alpha' named twice"});
}

// Oracle: floor(i n / k) by hand: 10 rows, 4 draws -> 0, 2, 5, 7; k >= n
// takes every row once.
TEST(PosteriorSamples, PicksEvenlySpacedRows) {
  EXPECT_EQ(PickDraws(10, 4), (std::vector<std::size_t>{0, 2, 5, 7}));
  EXPECT_EQ(PickDraws(3, 32), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(PickDraws(400, 1), (std::vector<std::size_t>{0}));
  EXPECT_THROW(PickDraws(10, 0), std::invalid_argument);
}

// Oracle: numpy.quantile(x, q) (linear, type 7) of x = 0, 1, ..., 10 is 10 q;
// of {3, 1, 2, 10} sorted (1, 2, 3, 10): h = 3 q, so q = 0.5 gives 2.5 and
// q = 0.84 gives 3 + 0.52 * 7 = 6.64 (hand arithmetic); exact to rounding.
TEST(BandQuantiles, MatchTheLinearInterpolationDefinition) {
  std::vector<double> x;
  for (int i = 0; i <= 10; ++i) x.push_back(10 - i);  // unsorted: ComputeBand sorts
  const BandQuantiles q = ComputeBand(x);
  EXPECT_NEAR(q.lo95, 0.25, 1e-12);
  EXPECT_NEAR(q.lo68, 1.6, 1e-12);
  EXPECT_NEAR(q.median, 5.0, 1e-12);
  EXPECT_NEAR(q.hi68, 8.4, 1e-12);
  EXPECT_NEAR(q.hi95, 9.75, 1e-12);
  std::vector<double> y{3, 1, 2, 10};
  const BandQuantiles r = ComputeBand(y);
  EXPECT_NEAR(r.median, 2.5, 1e-12);
  EXPECT_NEAR(r.hi68, 6.64, 1e-12);
  std::vector<double> one{0.7};
  EXPECT_EQ(ComputeBand(one).lo95, 0.7);
  std::vector<double> none;
  EXPECT_TRUE(std::isnan(ComputeBand(none).median));
}

// Oracle: a closed form. Members all at theta0 with one sigma: the mixture
// is N(theta0, sigma^2), whose quantiles are theta0 + sigma z_q with the
// standard normal's z_0.975 = 1.959963985, z_0.84 = 0.994457883 (tables);
// to 1e-9 sigma (the solver's 1e-12 rad and the tables' 10 digits).
TEST(BandQuantiles, NoisyBandOfEqualMembersIsTheGaussians) {
  const std::vector<double> values(32, 0.01), sigmas(32, 2e-4);
  const BandQuantiles q = ComputeNoisyBand(values, sigmas);
  EXPECT_NEAR(q.median, 0.01, 1e-13);
  EXPECT_NEAR(q.hi95, 0.01 + 2e-4 * 1.959963985, 2e-13);
  EXPECT_NEAR(q.lo95, 0.01 - 2e-4 * 1.959963985, 2e-13);
  EXPECT_NEAR(q.hi68, 0.01 + 2e-4 * 0.994457883, 2e-13);
  EXPECT_NEAR(q.lo68, 0.01 - 2e-4 * 0.994457883, 2e-13);
}

// Oracle: the definition, evaluated here. For members spread wider than
// their noise, each quantile x_q satisfies (1/n) sum Phi((x_q - theta_k) /
// sigma_k) = q (Phi written with std::erf here) to 1e-9.
TEST(BandQuantiles, NoisyBandSolvesTheMixturesDistribution) {
  const std::vector<double> values{0.0, 0.01, 0.03, -0.02, 0.012};
  const std::vector<double> sigmas{0.002, 0.005, 0.001, 0.0005, 0.003};
  const BandQuantiles b = ComputeNoisyBand(values, sigmas);
  auto cdf = [&](double x) {
    double f = 0;
    for (std::size_t k = 0; k < values.size(); ++k) f += 0.5 * (1 + std::erf((x - values[k]) / (sigmas[k] * std::sqrt(2.0))));
    return f / static_cast<double>(values.size());
  };
  EXPECT_NEAR(cdf(b.lo95), 0.025, 1e-9);
  EXPECT_NEAR(cdf(b.lo68), 0.16, 1e-9);
  EXPECT_NEAR(cdf(b.median), 0.5, 1e-9);
  EXPECT_NEAR(cdf(b.hi68), 0.84, 1e-9);
  EXPECT_NEAR(cdf(b.hi95), 0.975, 1e-9);
}

// Quantile q of `values` by counting: the value v with a fraction q of the
// (n - 1) gaps below it, interpolated between order statistics found by
// selection (std::nth_element), not by sorting as the library does.
double QuantileBySelection(std::vector<double> values, double q) {
  const double h = (static_cast<double>(values.size()) - 1) * q;
  const auto i = static_cast<std::size_t>(std::floor(h));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(i), values.end());
  const double lo = values[i];
  if (i + 1 >= values.size()) return lo;
  const double hi = *std::min_element(values.begin() + static_cast<long>(i) + 1, values.end());
  return lo + (h - std::floor(h)) * (hi - lo);
}

// Oracle: each draw run on its own through the library (same calls as the
// node: Reset at the start, Step per sample with the node's integrator), its
// theta collected, and the five quantiles computed by selection in the test;
// the node's RL_BAND equals them (same arithmetic per member: 1e-12 rad).
// The impacts the band reports over the run add up to the members' own
// impact counts, and their offsets place each impact inside its sample.
TEST(ModelNodeEnsemble, BandIsTheQuantilesOfTheDrawsRunOneByOne) {
  const std::string path = WriteFile("draws.csv",
                                     "alpha,p,mu,log_posterior\n"
                                     "0.230,3.88,0.930,-1\n0.233,3.86,0.935,-1\n0.235,3.884,0.937,-1\n"
                                     "0.237,3.90,0.940,-1\n0.240,3.87,0.925,-1\n0.232,3.89,0.945,-1\n"
                                     "0.238,3.85,0.933,-1\n");
  ModelNodeConfig config;
  config.ensembles.push_back(MakeEnsemble("post", ModelKind::kHousner, path, 7, ModelOptions{}));
  common::DirectBus bus;
  std::vector<rocklab::model_band_t> bands;
  const common::Subscription sub = bus.Subscribe<rocklab::model_band_t>(
      "RL_BAND_post", [&](const std::string&, const rocklab::model_band_t& m) { bands.push_back(m); });
  ModelNode node(config, bus);

  std::vector<std::unique_ptr<RockingModel>> direct;
  ModelOptions options;
  options.integrator = config.integrator;
  for (const PosteriorDraw& d : config.ensembles[0].draws) {
    direct.push_back(RockingModel::Create(ModelKind::kHousner, d.params, options));
    direct.back()->Reset(0.0, 0.08, 0.0);
  }
  node.HandleTheta(Theta(0, 0.08));
  int impacts_direct = 0, impacts_band = 0;
  for (int k = 0; k < 3000; ++k) {  // 3 s of free rocking at 1 kHz
    node.HandleTable(Table(1000 * k, 0.0));
    std::vector<double> thetas;
    for (auto& m : direct) {
      m->Step(k * 1e-3, 0.0);
      thetas.push_back(m->state().theta);
    }
    ASSERT_EQ(bands.size(), static_cast<std::size_t>(k + 1));
    const rocklab::model_band_t& b = bands.back();
    ASSERT_EQ(b.members, 7);
    ASSERT_NEAR(b.theta_lo95, QuantileBySelection(thetas, 0.025), 1e-12) << "sample " << k;
    ASSERT_NEAR(b.theta_lo68, QuantileBySelection(thetas, 0.16), 1e-12) << "sample " << k;
    ASSERT_NEAR(b.theta_median, QuantileBySelection(thetas, 0.5), 1e-12) << "sample " << k;
    ASSERT_NEAR(b.theta_hi68, QuantileBySelection(thetas, 0.84), 1e-12) << "sample " << k;
    ASSERT_NEAR(b.theta_hi95, QuantileBySelection(thetas, 0.975), 1e-12) << "sample " << k;
    impacts_band += b.impacts_up + b.impacts_down;
    for (const auto& [n, sum] : {std::pair{b.impacts_up, b.impact_up_offset_sum},
                                 std::pair{b.impacts_down, b.impact_down_offset_sum}}) {
      EXPECT_LE(sum, 1e-12);  // each offset in (-1 ms, 0]
      EXPECT_GE(sum, -1e-3 * n - 1e-12);
    }
  }
  for (auto& m : direct) impacts_direct += m->state().impacts;
  EXPECT_EQ(impacts_band, impacts_direct);
  EXPECT_GT(impacts_direct, 7 * 3);  // every member rocked through several impacts
  EXPECT_EQ(bands.back().seq, 2999);
  EXPECT_EQ(bands.back().draws, 7);
  EXPECT_EQ(bands.back().model, "housner");
  EXPECT_EQ(node.member_failures(), 0);
}

// Oracle: a node with only an ensemble (no point variant) is a valid
// configuration; two ensembles of one name are not.
TEST(ModelNodeEnsemble, ConfigurationIsChecked) {
  const std::string path = WriteFile("one.csv", "alpha,p,mu\n0.235,3.884,0.937\n");
  ModelNodeConfig config;
  config.ensembles.push_back(MakeEnsemble("e", ModelKind::kComplex, path, 4, ModelOptions{}));
  EXPECT_EQ(config.ensembles[0].draws.size(), 1u);
  EXPECT_NO_THROW(config.Validate());
  config.ensembles.push_back(config.ensembles[0]);
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  EXPECT_THROW(MakeEnsemble("bad-name", ModelKind::kComplex, path, 4, ModelOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::model
