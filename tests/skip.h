#pragma once
// The one way a test skips: ROCKLAB_SKIP(reason). On a developer's machine
// without root or Chromium it skips with the reason; with CI=true in the
// environment (tools/test.sh in CI, which runs as root with both installed
// by tools/setup.sh) it fails instead, so a layer never goes untested there
// while the suite stays green.

#include <cstdlib>
#include <cstring>
#include <string>

#include <gtest/gtest.h>

namespace rocklab::test {

/// True when CI=true is in the environment.
inline bool InCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::strcmp(ci, "true") == 0;
}

}  // namespace rocklab::test

/// Skips the current test with `reason` (a std::string or string literal),
/// or fails it when InCi(). Returns from the test function either way.
#define ROCKLAB_SKIP(reason)                                                          \
  do {                                                                                \
    const std::string rocklab_skip_reason_ = (reason);                                \
    if (::rocklab::test::InCi()) {                                                    \
      GTEST_FAIL() << "CI=true: this test may not skip: " << rocklab_skip_reason_;    \
    }                                                                                 \
    GTEST_SKIP() << rocklab_skip_reason_;                                             \
  } while (false)
