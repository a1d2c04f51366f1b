// SubscriberUrl: the receive buffer a subscribing node asks for. Oracle: the
// URL strings LCM 1.3.1 parses (udpm://ADDR:PORT?opt=v&opt=v).
#include <cstdlib>

#include <gtest/gtest.h>

#include "tools/cli.h"

namespace rocklab::tools {
namespace {

TEST(SubscriberUrl, UdpmWithoutABufferGetsFourMebibytes) {
  EXPECT_EQ(SubscriberUrl("udpm://239.255.76.67:7667?ttl=0"),
            "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(SubscriberUrl("udpm://239.255.76.67:7667"),
            "udpm://239.255.76.67:7667?recv_buf_size=4194304");
}

TEST(SubscriberUrl, AnExplicitBufferAndOtherProvidersAreKept) {
  EXPECT_EQ(SubscriberUrl("udpm://239.255.76.67:7667?recv_buf_size=65536&ttl=0"),
            "udpm://239.255.76.67:7667?recv_buf_size=65536&ttl=0");
  EXPECT_EQ(SubscriberUrl("memq://"), "memq://");
  EXPECT_EQ(SubscriberUrl("file:///tmp/x.lcm?mode=r"), "file:///tmp/x.lcm?mode=r");
}

TEST(SubscriberUrl, EmptyMeansLcmDefaultUrlThenLcmsOwnDefault) {
  ASSERT_EQ(setenv("LCM_DEFAULT_URL", "udpm://239.255.76.68:7668?ttl=0", 1), 0);
  EXPECT_EQ(SubscriberUrl(""), "udpm://239.255.76.68:7668?ttl=0&recv_buf_size=4194304");
  ASSERT_EQ(setenv("LCM_DEFAULT_URL", "memq://", 1), 0);
  EXPECT_EQ(SubscriberUrl(""), "memq://");
  ASSERT_EQ(unsetenv("LCM_DEFAULT_URL"), 0);
  EXPECT_EQ(SubscriberUrl(""), "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
}

}  // namespace
}  // namespace rocklab::tools
