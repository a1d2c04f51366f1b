// rocklab::pipeline as a library: the nodes' configurations from the rig
// file and option values, errors naming the option.
#include "pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <string>

#include "model/block.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

using ::rocklab::test::kLabRig;  // tests/source_paths.h

// Oracle: the documented default (Housner and the complex formulation with
// the rig's geometric parameters) and RectangleBlock's parameters.
TEST(PipelineStages, DefaultVariantsUseTheRigsGeometry) {
  const daq::RigConfig rig = LoadRig(kLabRig);
  const model::BlockParams theory =
      model::RectangleBlock(rig.block.width_m, rig.block.height_m, rig.block.chamfer_m).params();
  const auto variants = BuildVariants({}, rig);
  ASSERT_EQ(variants.size(), 2u);
  EXPECT_EQ(variants[0].name, "housner");
  EXPECT_EQ(variants[1].name, "complex");
  EXPECT_EQ(variants[1].params.alpha, theory.alpha);
  EXPECT_EQ(TheoreticalParams(rig).p, theory.p);
  const daq::DaqNodeConfig daq = DaqConfigFor(rig, "x.csv", 0.0);
  ASSERT_TRUE(daq.rig.block.alpha.has_value());
  EXPECT_EQ(*daq.rig.block.mu, rig.block.mu.value_or(theory.mu));
}

// Oracle: the CLI's error convention: the message starts with the option.
TEST(PipelineStages, ErrorsNameTheOption) {
  try {
    LoadRig("/nonexistent/rig.toml");
    ADD_FAILURE() << "no error";
  } catch (const OptionError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--rig: ", 0), 0u) << e.what();
  }
  const daq::RigConfig rig = LoadRig(kLabRig);
  try {
    BuildVariants({"a:housner:theoretical", "a:complex:theoretical"}, rig);
    ADD_FAILURE() << "no error";
  } catch (const OptionError& e) {
    EXPECT_EQ(std::string(e.what()), "--variant: name 'a' used twice");
  }
  compare::CompareNodeConfig c;
  c.publish_rate_hz = 0;
  EXPECT_THROW(ValidateCompareOptions(c), OptionError);
  EXPECT_THROW(OpenLcmBus("nonsense://"), OptionError);
}

}  // namespace
}  // namespace rocklab::pipeline
