// common/provenance.h: SHA-256 and the provenance record of written files.
#include "common/provenance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <cstdint>
#include <utility>
#include <vector>
#include <map>
#include <filesystem>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "tests/scratch.h"
#include "tests/sha256sum.h"

namespace rocklab::common {
namespace {

std::string ProvenanceTestBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

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

// Both block functions, the portable rounds and the x86 SHA extensions
// (where this CPU has them; else the portable one twice), on the FIPS
// examples and on pseudo-random messages of every length to 300 bytes fed
// in uneven pieces. Oracle: FIPS 180-4's digests, then each other.
TEST(Sha256, ThePortableRoundsAndTheCpuExtensionsGiveTheSameDigests) {
  const auto hash = [](const std::string& bytes, Sha256::Rounds rounds, std::size_t piece) {
    Sha256 h(rounds);
    for (std::size_t i = 0; i < bytes.size(); i += piece) h.Update(bytes.data() + i, std::min(piece, bytes.size() - i));
    return h.HexDigest();
  };
  for (const Sha256::Rounds rounds : {Sha256::Rounds::kPortable, Sha256::Rounds::kFastest}) {
    EXPECT_EQ(hash("abc", rounds, 3), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    EXPECT_EQ(hash(std::string(1000000, 'a'), rounds, 4096),
              "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  }
  std::uint32_t x = 12345;
  std::string bytes;
  for (int n = 0; n <= 300; ++n) {
    EXPECT_EQ(hash(bytes, Sha256::Rounds::kFastest, 7), hash(bytes, Sha256::Rounds::kPortable, 64)) << n << " bytes";
    x = x * 1664525u + 1013904223u;
    bytes += static_cast<char>(x >> 24);
  }
  std::printf("the CPU's SHA extensions: %s\n", Sha256::CpuHasShaExtensions() ? "used" : "absent");
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

// Oracle: the check value of CRC-32 (ISO-HDLC, the PNG's: reflected
// 0xEDB88320, init and final xor 0xFFFFFFFF) over "123456789", 0xCBF43926,
// as the CRC catalogues list it; and the CRC of PNG's own IEND chunk type,
// 0xAE426082, which every PNG ends with.
TEST(Provenance, PngCrcMatchesTheCheckValues) {
  EXPECT_EQ(PngCrc32("123456789", 9), 0xCBF43926u);
  EXPECT_EQ(PngCrc32("IEND", 4), 0xAE426082u);
}

// A CSV's sidecar: STEM.provenance.csv, key,value quoted as `export` writes
// it; the source's hash against coreutils' sha256sum; nothing for "-".
TEST(Provenance, SidecarBesideACsvHoldsTheFieldsAndTheSourcesHash) {
  EXPECT_EQ(ProvenanceSidecarPath("a/b.csv"), "a/b.provenance.csv");
  EXPECT_EQ(ProvenanceSidecarPath("raw.lvm"), "raw.lvm.provenance.csv");
  const std::string dir = test::ScratchDir("provenance_sidecar");
  const std::string source = dir + "/in.csv";
  std::ofstream(source, std::ios::binary) << "time,accel\n0,1\n";
  const std::string out = dir + "/out.csv";
  std::ofstream(out, std::ios::binary) << "time,theta\n";
  WriteProvenanceSidecar(out, {source});
  WriteProvenanceSidecar("-", {source});  // standard output: no file
  std::ifstream in(dir + "/out.provenance.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "key,value");
  std::map<std::string, std::string> fields;
  while (std::getline(in, line)) {
    const std::regex row(R"re("([a-z0-9_]+)","(.*)")re");
    std::smatch m;
    ASSERT_TRUE(std::regex_match(line, m, row)) << line;
    fields[m[1]] = m[2];
  }
  const std::string hash = test::Sha256sum(source);
  ASSERT_EQ(hash.size(), 64u);
  EXPECT_EQ(fields["source_1"],
            source + " (" + std::to_string(std::filesystem::file_size(source)) + " bytes, sha256 " + hash + ")");
  EXPECT_EQ(fields["rocklab_version"], ROCKLAB_TEST_VERSION);
  EXPECT_EQ(ProvenanceTestBytes(out), "time,theta\n");  // the CSV untouched
  EXPECT_FALSE(std::filesystem::exists(dir + "/-.provenance.csv"));
  // A device is not read (it might never end): kept as not readable.
  const Provenance p = MakeProvenance({"/dev/zero"});
  ASSERT_EQ(p.sources.size(), 1u);
  EXPECT_EQ(p.sources[0].size_bytes, -1);
}

// Oracle: MakeProvenance over the same paths and coreutils' sha256sum of
// each file as it is at Finish: the same sources whether the hash ran
// before or after the file changed (one file is appended to after the
// hashing thread started, so its size moved and it is hashed again).
TEST(Provenance, HashedInTheBackgroundAsMakeProvenanceWould) {
  const std::string dir = test::ScratchDir("provenance_background");
  const std::string kept = dir + "/kept.csv";
  const std::string grown = dir + "/grown.csv";
  std::ofstream(kept, std::ios::binary) << std::string(300000, 'k');
  std::ofstream(grown, std::ios::binary) << std::string(300000, 'g');
  const std::vector<std::string> paths = {kept, "", grown, kept, dir + "/missing.csv", "-"};
  ProvenanceInBackground hashing(paths);
  std::ofstream(grown, std::ios::binary | std::ios::app) << "more";
  const Provenance p = hashing.Finish();
  const Provenance oracle = MakeProvenance(paths);
  ASSERT_EQ(p.sources.size(), 3u);
  ASSERT_EQ(oracle.sources.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(p.sources[i].path, oracle.sources[i].path);
    EXPECT_EQ(p.sources[i].size_bytes, oracle.sources[i].size_bytes);
    EXPECT_EQ(p.sources[i].sha256, oracle.sources[i].sha256);
  }
  EXPECT_EQ(p.sources[0].sha256, test::Sha256sum(kept));
  EXPECT_EQ(p.sources[1].sha256, test::Sha256sum(grown));
  EXPECT_EQ(p.sources[1].size_bytes, 300004);
  EXPECT_EQ(p.sources[2].size_bytes, -1);
  EXPECT_EQ(p.rocklab_version, oracle.rocklab_version);
  EXPECT_EQ(p.command, oracle.command);
}

// SVG: a <metadata> element after the start tag, its text XML-escaped;
// PNG: tEXt chunks before IEND, each with a CRC that a table-driven CRC-32
// written here (Oracle: an independent implementation, checked against the
// check value above) agrees with; a file of neither kind is left alone.
TEST(Provenance, FiguresCarryTheFieldsWithoutChangingThePicture) {
  const std::string dir = test::ScratchDir("provenance_figures");
  const std::vector<std::pair<std::string, std::string>> fields = {{"command", "a <b> & \"c\""}, {"source_1", "x"}};
  const std::string svg = dir + "/f.svg";
  const std::string picture = "<svg width=\"10\" height=\"10\"><rect/></svg>\n";
  std::ofstream(svg, std::ios::binary) << "<?xml version=\"1.0\"?>\n" << picture;
  ASSERT_TRUE(AddProvenanceToFigure(svg, fields));
  const std::string svg_text = ProvenanceTestBytes(svg);
  EXPECT_NE(svg_text.find("<svg width=\"10\" height=\"10\">\n<metadata>\n"), std::string::npos) << svg_text;
  EXPECT_NE(svg_text.find("key=\"command\">a &lt;b&gt; &amp; &quot;c&quot;</rocklab:provenance>"),
            std::string::npos) << svg_text;
  EXPECT_NE(svg_text.find("</metadata><rect/></svg>"), std::string::npos) << svg_text;

  // The smallest PNG frame: signature, a 1x1 IHDR, IEND (its CRCs from the table below).
  std::uint32_t table[256];
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  const auto crc = [&table](const std::string& bytes) {
    std::uint32_t c = 0xFFFFFFFFu;
    for (unsigned char b : bytes) c = table[(c ^ b) & 0xFFu] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
  };
  ASSERT_EQ(crc("123456789"), 0xCBF43926u);
  const auto be32 = [](std::uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>((v >> 16) & 0xFF), static_cast<char>((v >> 8) & 0xFF),
                       static_cast<char>(v & 0xFF)};
  };
  const auto chunk = [&](const std::string& type_and_data) {
    return be32(static_cast<std::uint32_t>(type_and_data.size() - 4)) + type_and_data + be32(crc(type_and_data));
  };
  const std::string ihdr = chunk(std::string("IHDR\0\0\0\1\0\0\0\1\x08\x02\0\0\0", 17));
  const std::string png_bytes = std::string("\x89PNG\r\n\x1a\n", 8) + ihdr + chunk("IEND");
  const std::string png = dir + "/f.png";
  std::ofstream(png, std::ios::binary) << png_bytes;
  ASSERT_TRUE(AddProvenanceToFigure(png, fields));
  const std::string got = ProvenanceTestBytes(png);
  // Walk the chunks: every CRC right, the text chunks between IHDR and IEND.
  std::size_t at = 8;
  std::vector<std::string> types, texts;
  while (at + 12 <= got.size()) {
    const auto b = [&](std::size_t i) { return static_cast<std::uint32_t>(static_cast<unsigned char>(got[i])); };
    const std::uint32_t length = b(at) << 24 | b(at + 1) << 16 | b(at + 2) << 8 | b(at + 3);
    const std::string body = got.substr(at + 4, 4 + length);
    const std::uint32_t stored = b(at + 8 + length) << 24 | b(at + 9 + length) << 16 | b(at + 10 + length) << 8 |
                                 b(at + 11 + length);
    EXPECT_EQ(stored, crc(body)) << body.substr(0, 4);
    types.push_back(body.substr(0, 4));
    if (types.back() == "tEXt") texts.push_back(body.substr(4));
    at += 12 + length;
  }
  EXPECT_EQ(at, got.size());
  EXPECT_EQ(types, (std::vector<std::string>{"IHDR", "tEXt", "tEXt", "IEND"}));
  ASSERT_EQ(texts.size(), 2u);
  EXPECT_EQ(texts[0], std::string("rocklab_command\0a <b> & \"c\"", 27));
  EXPECT_EQ(texts[1], std::string("rocklab_source_1\0x", 18));

  const std::string other = dir + "/f.txt";
  std::ofstream(other, std::ios::binary) << "not a figure\n";
  EXPECT_FALSE(AddProvenanceToFigure(other, fields));
  EXPECT_EQ(ProvenanceTestBytes(other), "not a figure\n");
}

}  // namespace
}  // namespace rocklab::common
