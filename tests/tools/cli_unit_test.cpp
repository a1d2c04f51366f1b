// tools/cli.h's typo helpers called directly: EditDistance against
// hand-counted edits, DidYouMean's thresholds, UnknownOption on a small app.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tools/cli.h"

namespace rocklab::tools {
namespace {

// Oracle: edits counted by hand (the classic kitten/sitting is 3).
TEST(CliTypos, EditDistance) {
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(EditDistance("", "abc"), 3u);
  EXPECT_EQ(EditDistance("--duraton", "--duration"), 1u);
  EXPECT_EQ(EditDistance("sweep-plot", "sweepplot"), 1u);
  EXPECT_EQ(EditDistance("same", "same"), 0u);
  // A swap of neighbours is one edit (Levenshtein counts two).
  EXPECT_EQ(EditDistance("--otu", "--out"), 1u);
  EXPECT_EQ(EditDistance("--sgv", "--svg"), 1u);
  EXPECT_EQ(EditDistance("ab", "ba"), 1u);
  EXPECT_EQ(EditDistance("ca", "abc"), 3u);  // optimal string alignment: no edit of a swapped pair
}

TEST(CliTypos, DidYouMean) {
  const std::vector<std::string> names = {"simulate", "sweep", "sweep-plot", "synth", "info"};
  EXPECT_EQ(DidYouMean("simulat", names), "simulate");
  EXPECT_EQ(DidYouMean("swep", names), "sweep");
  EXPECT_EQ(DidYouMean("imfo", names), "info");
  EXPECT_EQ(DidYouMean("frobnicate", names), "");
  EXPECT_EQ(DidYouMean("sim", names), "simulate");  // the start of one name only
  EXPECT_EQ(DidYouMean("s", names), "");            // the start of several
}

TEST(CliTypos, UnknownOption) {
  CLI::App app{"test"};
  CLI::App* cmd = app.add_subcommand("simulate", "");
  double duration = 0;
  std::string out;
  cmd->add_option("--duration", duration, "")->required();
  cmd->add_option("--out,-o", out, "");
  EXPECT_EQ(UnknownOption(*cmd, {"--duration", "5", "-o", "x", "--out=y", "-0.5"}), "");
  EXPECT_EQ(UnknownOption(*cmd, {"--", "--duraton"}), "");  // after --: positionals
  const std::string m = UnknownOption(*cmd, {"--duraton", "5"});
  EXPECT_NE(m.find("unknown option --duraton (did you mean --duration?)"), std::string::npos) << m;
  EXPECT_NE(UnknownOption(*cmd, {"-x"}).find("unknown option -x"), std::string::npos);
  // The typos: swapped letters.
  EXPECT_NE(UnknownOption(*cmd, {"--otu", "x"}).find("(did you mean --out?)"), std::string::npos);
}

}  // namespace
}  // namespace rocklab::tools
