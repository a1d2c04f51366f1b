// common::ChannelPattern: a user's channel pattern compiled with bounds.
// Oracle: the patterns below, whose length and depth are counted by
// construction; std::regex on the accepted ones.
#include "common/channel_pattern.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace rocklab::common {
namespace {

std::string Nested(int levels, const std::string& inner) {
  return std::string(static_cast<std::size_t>(levels), '(') + inner + std::string(static_cast<std::size_t>(levels), ')');
}

std::string MessageOf(const std::string& pattern) {
  try {
    ChannelPattern(pattern, "--channels");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ChannelPattern, APatternWithinTheBoundsMatchesAsStdRegex) {
  const std::regex re = ChannelPattern(Nested(kMaxChannelPatternDepth - 1, "RL_(THETA|TABLE)"), "--channels");
  EXPECT_TRUE(std::regex_match("RL_THETA", re));
  EXPECT_FALSE(std::regex_match("RL_RAW", re));
  // Brackets and an escaped parenthesis are not groups (99 backslashes: 49
  // escaped backslashes, then \( ).
  EXPECT_NO_THROW(ChannelPattern(std::string(200, '[') + "]" + std::string(99, '\\') + "(", "--channels"));
}

// Issue 34: 20 000 nested groups overflowed the stack inside std::regex
// (SIGSEGV in Python, exit 139 in export); now a message names the option.
TEST(ChannelPattern, DeeplyNestedGroupsAreRefusedNotACrash) {
  const std::string msg = MessageOf(Nested(20000, "RL_THETA"));
  EXPECT_NE(msg.find("--channels: the pattern '((("), std::string::npos) << msg;
  EXPECT_NE(msg.find("longer than 1024 bytes"), std::string::npos) << msg;
  const std::string deep = MessageOf(Nested(kMaxChannelPatternDepth + 1, "A"));
  EXPECT_NE(deep.find("nests groups 33 deep, more than 32"), std::string::npos) << deep;
}

TEST(ChannelPattern, ALongFlatPatternIsRefused) {
  const std::string msg = MessageOf(std::string(30000, 'a'));
  EXPECT_NE(msg.find("longer than 1024 bytes"), std::string::npos) << msg;
  EXPECT_LT(msg.size(), 200u);  // the pattern is quoted cut, not whole
}

TEST(ChannelPattern, NotARegexSaysSo) {
  const std::string msg = MessageOf("(");
  EXPECT_EQ(msg.rfind("--channels: not a regular expression '('", 0), 0u) << msg;
}

}  // namespace
}  // namespace rocklab::common
