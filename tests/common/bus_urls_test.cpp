// Where the raw frames go (common/bus_urls.h): the raw URL derived from the
// main one, `--raw-url same` and explicit URLs, the errors naming the option,
// and the routing bus that sends RL_RAW to a second bus.
// Oracle: the rule as docs/channels.md states it, written out by hand for
// each case (group's last octet + 1, 255 -> 0; port + 1; options as given;
// any provider but udpm: the main bus).
#include "common/bus_urls.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "common/routing_bus.h"

namespace rocklab::common {
namespace {

// The message of RawUrl's exception, "" when it does not throw.
std::string RawUrlError(const std::string& main, const std::string& option) {
  try {
    RawUrl(main, option);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(RawUrl, LcmDefaultGroupGetsTheNextGroupAndPort) {
  EXPECT_EQ(RawUrl("udpm://239.255.76.67:7667?ttl=0", ""), "udpm://239.255.76.68:7668?ttl=0");
  EXPECT_EQ(RawUrl("udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304", ""),
            "udpm://239.255.76.68:7668?ttl=1&recv_buf_size=4194304");
  EXPECT_EQ(RawUrl("udpm://239.255.76.67:7667", ""), "udpm://239.255.76.68:7668");
}

TEST(RawUrl, UserGroupsFollowTheSameRule) {
  EXPECT_EQ(RawUrl("udpm://239.1.2.3:9000?ttl=0", ""), "udpm://239.1.2.4:9001?ttl=0");
  EXPECT_EQ(RawUrl("udpm://239.1.2.255:9000?ttl=0", ""), "udpm://239.1.2.0:9001?ttl=0");  // wraps
  EXPECT_EQ(RawUrl("udpm://239.1.2.3?ttl=0", ""), "udpm://239.1.2.4:7668?ttl=0");        // LCM's port
  EXPECT_EQ(RawUrl("udpm://", ""), "udpm://239.255.76.68:7668");                          // LCM's group
  EXPECT_EQ(RawUrl("udpm://?ttl=0", ""), "udpm://239.255.76.68:7668?ttl=0");
}

TEST(RawUrl, OtherProvidersKeepOneBus) {
  EXPECT_EQ(RawUrl("memq://", ""), "");
  EXPECT_EQ(RawUrl("file:///tmp/x.lcm?mode=w", ""), "");
  EXPECT_EQ(RawUrl("tcpq://127.0.0.1:7700", ""), "");
}

TEST(RawUrl, EmptyMainIsLcmDefaultUrlElseLcmsOwn) {
  const char* saved = std::getenv("LCM_DEFAULT_URL");
  const std::string keep = saved != nullptr ? saved : "";
  ::unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(ResolveLcmUrl(""), "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(RawUrl("", ""), "udpm://239.255.76.68:7668?ttl=0");
  ::setenv("LCM_DEFAULT_URL", "udpm://239.9.9.9:5000?ttl=0", 1);
  EXPECT_EQ(RawUrl("", ""), "udpm://239.9.9.10:5001?ttl=0");
  ::setenv("LCM_DEFAULT_URL", "memq://", 1);
  EXPECT_EQ(RawUrl("", ""), "");
  if (saved != nullptr) {
    ::setenv("LCM_DEFAULT_URL", keep.c_str(), 1);
  } else {
    ::unsetenv("LCM_DEFAULT_URL");
  }
}

TEST(RawUrl, SameAndExplicitUrls) {
  const std::string main = "udpm://239.255.76.67:7667?ttl=0";
  EXPECT_EQ(RawUrl(main, "same"), "");
  EXPECT_EQ(RawUrl("memq://", "same"), "");
  EXPECT_EQ(RawUrl(main, "udpm://239.255.80.1:7700?ttl=0"), "udpm://239.255.80.1:7700?ttl=0");
  EXPECT_EQ(RawUrl("memq://", "udpm://239.255.80.1:7700?ttl=0"), "udpm://239.255.80.1:7700?ttl=0");
  // The main group and port, whatever the options: the main bus (two
  // instances on one address would each receive every message).
  EXPECT_EQ(RawUrl(main, "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=65536"), "");
  EXPECT_EQ(RawUrl(main, "udpm://239.255.76.67?ttl=0"), "");  // LCM's port
  EXPECT_EQ(RawUrl("memq://", "memq://"), "");
  EXPECT_EQ(RawUrl(main, "memq://"), "memq://");
}

TEST(RawUrl, BadUrlsNameTheOption) {
  const std::string main = "udpm://239.255.76.67:7667?ttl=0";
  for (const std::string bad : {"bogus", "udp://239.1.1.1:1", "udpm://239.1.1:7667", "udpm://239.1.1.1.1:7667",
                                "udpm://239.1.1.256:7667", "udpm://10.0.0.1:7667", "udpm://239.1.1.1:0",
                                "udpm://239.1.1.1:65536", "udpm://239.1.1.1:76x", "udpm://239.1.1.1:",
                                "udpm://lab-host:7667", "Same"}) {
    const std::string what = RawUrlError(main, bad);
    EXPECT_EQ(what.rfind("--raw-url: ", 0), 0u) << bad << ": " << what;
    EXPECT_NE(what.find(bad), std::string::npos) << bad << ": " << what;
  }
  // The main port with another group: the main sockets would receive it
  // (Linux, INADDR_ANY sockets once the machine joined both groups).
  const std::string shared = RawUrlError(main, "udpm://239.255.76.68:7667?ttl=0");
  EXPECT_EQ(shared.rfind("--raw-url: ", 0), 0u) << shared;
  EXPECT_NE(shared.find("port 7667"), std::string::npos) << shared;
  EXPECT_NE(RawUrlError("udpm://239.1.1.1?ttl=0", "udpm://239.1.1.9:7667"), "");  // LCM's port on both
  // No next port to derive: the message says what to give instead.
  const std::string what = RawUrlError("udpm://239.1.1.1:65535?ttl=0", "");
  EXPECT_EQ(what.rfind("--raw-url: ", 0), 0u) << what;
  EXPECT_NE(what.find("65535"), std::string::npos) << what;
  EXPECT_NE(what.find("--raw-url same"), std::string::npos) << what;
}

TEST(RawChannel, PrefixAndExactRegex) {
  EXPECT_EQ(RawChannel(), "RL_RAW");
  EXPECT_EQ(RawChannel("LAB2."), "LAB2.RAW");
  EXPECT_EQ(ExactChannelRegex("LAB2.RAW"), "LAB2\\.RAW");
  EXPECT_EQ(ExactChannelRegex("a+b(c)"), "a\\+b\\(c\\)");
}

// RL_RAW (exactly) goes to the second bus, every other channel to the main
// one; subscriptions are the main bus's.
TEST(RoutingBus, SendsTheMatchingChannelsToTheRoutedBus) {
  DirectBus main, raw;
  std::map<std::string, int> on_main, on_raw;
  const common::Subscription sub1 = main.SubscribeRaw(".*", [&](const std::string& ch, const void*, int) { ++on_main[ch]; });
  const common::Subscription sub2 = raw.SubscribeRaw(".*", [&](const std::string& ch, const void*, int) { ++on_raw[ch]; });
  RoutingBus bus(main, raw, ExactChannelRegex(RawChannel()));
  const char payload[4] = {1, 2, 3, 4};
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(bus.Publish("RL_RAW", payload, 4));
    EXPECT_TRUE(bus.Publish("RL_THETA", payload, 4));
  }
  EXPECT_TRUE(bus.Publish("RL_RAWX", payload, 4));  // the whole name must match
  EXPECT_TRUE(bus.Publish("XRL_RAW", payload, 4));
  EXPECT_EQ(on_raw, (std::map<std::string, int>{{"RL_RAW", 3}}));
  EXPECT_EQ(on_main, (std::map<std::string, int>{{"RL_THETA", 3}, {"RL_RAWX", 1}, {"XRL_RAW", 1}}));
  int seen = 0;
  const common::Subscription sub3 = bus.SubscribeRaw("RL_EVENT", [&](const std::string&, const void*, int) { ++seen; });
  main.Publish("RL_EVENT", payload, 4);
  EXPECT_EQ(seen, 1);
  EXPECT_THROW(RoutingBus(main, raw, "RL_(RAW"), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::common
