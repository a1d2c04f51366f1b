// The bundled sample tests (data/samples/README.md) reconstruct as their
// README says. Oracles: the truth files written beside them (fault times,
// the model's theta) and the lab rig's mirror noise (0.1 mm spot on a 2 m
// lever: sigma_theta = 2.5e-5 rad).
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "daq/processor.h"
#include "daq/source.h"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

struct Result {
  std::unique_ptr<test::CollectSink> sink = std::make_unique<test::CollectSink>();
  std::map<long, double> truth_theta;  // by sample number
};

Result ReconstructSample(const std::string& name) {
  const std::string dir = std::string(ROCKLAB_SOURCE_DIR) + "/data/samples/";
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  SourceOptions opt;
  opt.sample_rate_hz = rig.sample_rate_hz;
  auto source = OpenSource(dir + name, opt);
  Result r;
  Processor proc(rig, source->channel_names(), source->path(), *r.sink);
  Frame f;
  while (source->Next(f) == ReadStatus::kFrame) proc.Process(f);
  proc.Finish();
  std::ifstream truth(dir + name.substr(0, name.rfind('.')) + ".truth.csv");
  std::string line;
  std::getline(truth, line);
  while (std::getline(truth, line)) {
    std::stringstream s(line);
    double t = 0, theta = 0;
    char comma = 0;
    s >> t >> comma >> theta;
    r.truth_theta[std::lround(t * 1000)] = theta;
  }
  return r;
}

double FirstFlag(const Result& r, int32_t flag) {
  for (const auto& s : r.sink->block) {
    if (s.flags & flag) return s.time_s;
  }
  return -1;
}

constexpr int32_t kChecks = kFlagSliding | kFlagJump | kFlagTwist | kFlagOutOfPlane | kFlagDisagree;

TEST(Samples, FreeRockingIsCleanAndMatchesItsTruth) {
  const Result r = ReconstructSample("free_rocking.csv");
  ASSERT_GT(r.sink->block.size(), 990u);
  double max_err = 0;
  for (const auto& s : r.sink->block) {
    EXPECT_EQ(s.flags & kChecks, 0) << s.time_s;
    max_err = std::max(max_err, std::abs(s.theta - r.truth_theta.at(std::lround(s.time_s * 1000))));
  }
  EXPECT_LT(max_err, 6 * 2.5e-5);  // 6 sigma of the mirror noise
}

TEST(Samples, SlipIsFlaggedAtHalfASecond) {
  const Result r = ReconstructSample("slip.lvm");
  EXPECT_GE(FirstFlag(r, kFlagSliding), 0.5);
  EXPECT_LE(FirstFlag(r, kFlagSliding), 0.510);
  EXPECT_EQ(FirstFlag(r, kFlagTwist), -1);
}

TEST(Samples, TwistIsFlaggedAtSixTenths) {
  const Result r = ReconstructSample("twist.csv");
  EXPECT_GE(FirstFlag(r, kFlagTwist), 0.6);
  EXPECT_LE(FirstFlag(r, kFlagTwist), 0.610);
  EXPECT_EQ(FirstFlag(r, kFlagSliding), -1);
}

}  // namespace
}  // namespace rocklab::daq
