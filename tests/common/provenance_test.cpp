// common/provenance.h: SHA-256 and the provenance record of written files.
#include "common/provenance.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "tests/scratch.h"
#include "tests/sha256sum.h"

namespace rocklab::common {
namespace {

std::string HashOf(const std::string& bytes) {
  std::istringstream in(bytes);
  return Sha256Hex(in);
}

// Oracle: FIPS 180-4's examples (NIST's "SHA256.pdf" worked examples) and
// the million-'a' message of the NESSIE/FIPS 180-2 test set.
TEST(Sha256, FipsExamples) {
  EXPECT_EQ(HashOf(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(HashOf("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(HashOf("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(HashOf(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

// Oracle: coreutils' sha256sum over the same file, every length from 0 to
// 130 bytes (the padding's cases: 55, 56, 63, 64 bytes and over a block).
TEST(Sha256, AgreesWithSha256sumAcrossThePaddingCases) {
  const std::string dir = test::ScratchDir("sha256");
  std::string bytes;
  for (int n = 0; n <= 130; ++n) {
    const std::string path = dir + "/m" + std::to_string(n);
    std::ofstream(path, std::ios::binary) << bytes;
    const std::string oracle = test::Sha256sum(path);
    ASSERT_EQ(oracle.size(), 64u);
    EXPECT_EQ(HashOf(bytes), oracle) << n << " bytes";
    bytes += static_cast<char>(n * 37 + 11);
  }
}

TEST(Provenance, RecordsTheFilesTheCommandAndTheTime) {
  const std::string dir = test::ScratchDir("provenance");
  const std::string data = dir + "/in.csv";
  std::ofstream(data, std::ios::binary) << "time,a\n0,1\n";
  const Provenance p = MakeProvenance({data, "", data, dir + "/missing.csv"});
  EXPECT_EQ(p.rocklab_version, ROCKLAB_TEST_VERSION);
  EXPECT_FALSE(p.build_type.empty());
  EXPECT_NE(p.command.find("rocklab_tests_common"), std::string::npos) << p.command;
  EXPECT_TRUE(std::regex_match(p.created_utc, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"))) << p.created_utc;
  ASSERT_EQ(p.sources.size(), 2u);  // the empty and the repeated path left out
  EXPECT_EQ(p.sources[0].size_bytes, 11);
  EXPECT_EQ(p.sources[0].sha256, HashOf("time,a\n0,1\n"));
  EXPECT_EQ(p.sources[1].size_bytes, -1);
  EXPECT_EQ(p.sources[1].sha256, "");

  const nlohmann::json j = nlohmann::json::parse(ProvenanceJson(p));
  EXPECT_EQ(j["rocklab_version"], p.rocklab_version);
  EXPECT_EQ(j["command"], p.command);
  EXPECT_EQ(j["sources"][0]["path"], data);
  EXPECT_EQ(j["sources"][0]["size_bytes"], 11);
  const auto fields = ProvenanceFields(p);
  ASSERT_EQ(fields.size(), 6u);
  EXPECT_EQ(fields[4].first, "source_1");
  EXPECT_EQ(fields[5].first, "source_2");
  EXPECT_EQ(fields[4].second, data + " (11 bytes, sha256 " + p.sources[0].sha256 + ")");
  EXPECT_EQ(fields[5].second, dir + "/missing.csv (could not be read)");
}

}  // namespace
}  // namespace rocklab::common
