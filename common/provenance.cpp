#include "common/provenance.h"
#include "common/text.h"

#include "common/atomic_file.h"

#include <array>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

namespace rocklab::common {
namespace {

constexpr std::array<std::uint32_t, 64> kRoundConstants = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

constexpr std::uint32_t RotateRight(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

// A word of the command line for a POSIX shell: as it is when it holds only
// characters no shell treats specially, else in single quotes.
std::string ShellWord(const std::string& w) {
  bool plain = !w.empty();
  for (char c : w) {
    const bool safe = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      std::string_view("_-+=/.,:@%").find(c) != std::string_view::npos;
    plain = plain && safe;
  }
  if (plain) return w;
  std::string out = "'";
  for (char c : w) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string ThisCommandLine() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out;
  std::size_t start = 0;
  while (start < all.size()) {
    std::size_t end = all.find('\0', start);
    if (end == std::string::npos) end = all.size();
    if (!out.empty()) out += ' ';
    out += ShellWord(all.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

std::string NowUtc() { return UtcText(std::time(nullptr)); }

}  // namespace

std::string UtcText(std::time_t time) {
  std::tm utc{};
  gmtime_r(&time, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

Sha256::Sha256(Rounds rounds)
    : extensions_(rounds == Rounds::kFastest && CpuHasShaExtensions()),
      h_{0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19},
      buffer_{} {}

namespace {

// One round of FIPS 180-4 6.2.2 with the eight working variables renamed
// instead of moved: round i + 1 is called with (h, a, b, ..., g), so eight
// calls bring them back to their places.
inline void Sha256Round(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t& d, std::uint32_t e,
                        std::uint32_t f, std::uint32_t g, std::uint32_t& h, std::uint32_t kw) {
  const std::uint32_t t1 = h + (RotateRight(e, 6) ^ RotateRight(e, 11) ^ RotateRight(e, 25)) + (g ^ (e & (f ^ g))) + kw;
  const std::uint32_t t2 = (RotateRight(a, 2) ^ RotateRight(a, 13) ^ RotateRight(a, 22)) + ((a & b) | (c & (a | b)));
  d += t1;
  h = t1 + t2;
}

}  // namespace

#if defined(__x86_64__)
namespace {

// The x86 SHA extensions (Intel SHA-NI, AMD since Zen): with them a block
// takes ~5x less time than the portable rounds below, which made hashing a
// run's input (`rocklab run` hashes it for its provenance) about a sixth of
// run --max's CPU on a 600 s record. Same FIPS 180-4 function: the tests'
// FIPS examples and sha256sum comparisons run on whichever path the CPU has.
bool CpuHasShaExtensionsNow() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (__get_cpuid(1, &a, &b, &c, &d) == 0) return false;
  const bool ssse3 = (c & (1u << 9)) != 0, sse41 = (c & (1u << 19)) != 0;
  if (__get_cpuid_count(7, 0, &a, &b, &c, &d) == 0) return false;
  return ssse3 && sse41 && (b & (1u << 29)) != 0;  // CPUID.7.0:EBX.SHA
}

// The 64 rounds on one block, h = (a, b, ..., h). sha256rnds2 works on the
// state as (a, b, e, f) and (c, d, g, h) and does two rounds per call with
// the two round inputs in the low half of its third operand; sha256msg1 and
// sha256msg2 make the message schedule four words at a time.
__attribute__((target("sha,sse4.1,ssse3"))) void ShaExtensionsBlock(std::uint32_t* h, const unsigned char* p) {
  const __m128i big_endian = _mm_set_epi64x(0x0c0d0e0f08090a0bLL, 0x0405060700010203LL);
  const __m128i dcba = _mm_loadu_si128(reinterpret_cast<const __m128i*>(h));      // lanes a, b, c, d
  const __m128i hgfe = _mm_loadu_si128(reinterpret_cast<const __m128i*>(h + 4));  // lanes e, f, g, h
  const __m128i cdab = _mm_shuffle_epi32(dcba, 0xB1);
  const __m128i efgh = _mm_shuffle_epi32(hgfe, 0x1B);
  __m128i abef = _mm_alignr_epi8(cdab, efgh, 8);
  __m128i cdgh = _mm_blend_epi16(efgh, cdab, 0xF0);
  const __m128i abef0 = abef, cdgh0 = cdgh;
  __m128i w[4];  // words 4i .. 4i + 3 of the schedule in w[i % 4]
  for (int i = 0; i < 16; ++i) {
    __m128i x;
    if (i < 4) {
      x = _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 16 * i)), big_endian);
    } else {
      // W[t] = s1(W[t-2]) + W[t-7] + s0(W[t-15]) + W[t-16]
      x = _mm_sha256msg1_epu32(w[i & 3], w[(i + 1) & 3]);                   // W[t-16] + s0(W[t-15])
      x = _mm_add_epi32(x, _mm_alignr_epi8(w[(i + 3) & 3], w[(i + 2) & 3], 4));  // + W[t-7]
      x = _mm_sha256msg2_epu32(x, w[(i + 3) & 3]);                           // + s1(W[t-2])
    }
    w[i & 3] = x;
    __m128i kw = _mm_add_epi32(x, _mm_loadu_si128(reinterpret_cast<const __m128i*>(kRoundConstants.data() + 4 * i)));
    cdgh = _mm_sha256rnds2_epu32(cdgh, abef, kw);
    kw = _mm_shuffle_epi32(kw, 0x0E);
    abef = _mm_sha256rnds2_epu32(abef, cdgh, kw);
  }
  abef = _mm_add_epi32(abef, abef0);
  cdgh = _mm_add_epi32(cdgh, cdgh0);
  const __m128i feba = _mm_shuffle_epi32(abef, 0x1B);
  const __m128i dchg = _mm_shuffle_epi32(cdgh, 0xB1);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(h), _mm_blend_epi16(feba, dchg, 0xF0));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(h + 4), _mm_alignr_epi8(dchg, feba, 8));
}

}  // namespace
#endif

bool Sha256::CpuHasShaExtensions() {
#if defined(__x86_64__)
  static const bool has = CpuHasShaExtensionsNow();
  return has;
#else
  return false;
#endif
}

// The message schedule is kept in 16 words (w[i] overwrites w[i - 16]).
void Sha256::Block(const unsigned char* p) {
#if defined(__x86_64__)
  if (extensions_) {
    ShaExtensionsBlock(h_, p);
    return;
  }
#endif
  std::uint32_t w[16];
  for (int i = 0; i < 16; ++i) {
    w[i] = (std::uint32_t{p[4 * i]} << 24) | (std::uint32_t{p[4 * i + 1]} << 16) |
           (std::uint32_t{p[4 * i + 2]} << 8) | std::uint32_t{p[4 * i + 3]};
  }
  std::uint32_t a = h_[0], b = h_[1], c = h_[2], d = h_[3], e = h_[4], f = h_[5], g = h_[6], h = h_[7];
  for (int i = 0; i < 64; i += 8) {
    if (i >= 16) {
      for (int j = i; j < i + 8; ++j) {
        const std::uint32_t w15 = w[(j - 15) & 15], w2 = w[(j - 2) & 15];
        const std::uint32_t s0 = RotateRight(w15, 7) ^ RotateRight(w15, 18) ^ (w15 >> 3);
        const std::uint32_t s1 = RotateRight(w2, 17) ^ RotateRight(w2, 19) ^ (w2 >> 10);
        w[j & 15] += s0 + w[(j - 7) & 15] + s1;
      }
    }
    const std::uint32_t* k = kRoundConstants.data() + i;
    const std::uint32_t* wi = w + (i & 15);
    Sha256Round(a, b, c, d, e, f, g, h, k[0] + wi[0]);
    Sha256Round(h, a, b, c, d, e, f, g, k[1] + wi[1]);
    Sha256Round(g, h, a, b, c, d, e, f, k[2] + wi[2]);
    Sha256Round(f, g, h, a, b, c, d, e, k[3] + wi[3]);
    Sha256Round(e, f, g, h, a, b, c, d, k[4] + wi[4]);
    Sha256Round(d, e, f, g, h, a, b, c, k[5] + wi[5]);
    Sha256Round(c, d, e, f, g, h, a, b, k[6] + wi[6]);
    Sha256Round(b, c, d, e, f, g, h, a, k[7] + wi[7]);
  }
  h_[0] += a;
  h_[1] += b;
  h_[2] += c;
  h_[3] += d;
  h_[4] += e;
  h_[5] += f;
  h_[6] += g;
  h_[7] += h;
}

void Sha256::Update(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  total_bytes_ += bytes;
  while (bytes > 0) {
    if (buffered_ == 0 && bytes >= 64) {
      Block(p);
      p += 64;
      bytes -= 64;
      continue;
    }
    const std::size_t take = std::min(bytes, 64 - buffered_);
    std::copy(p, p + take, buffer_ + buffered_);
    buffered_ += take;
    p += take;
    bytes -= take;
    if (buffered_ == 64) {
      Block(buffer_);
      buffered_ = 0;
    }
  }
}

std::string Sha256::HexDigest() {
  // Padding: 0x80, zeros to 56 mod 64, the message length in bits (big-endian).
  const std::uint64_t bits = total_bytes_ * 8;
  const unsigned char one = 0x80, zero = 0;
  Update(&one, 1);
  while (buffered_ != 56) Update(&zero, 1);
  unsigned char length[8];
  for (int i = 0; i < 8; ++i) length[i] = static_cast<unsigned char>(bits >> (56 - 8 * i));
  Update(length, 8);
  char hex[65];
  for (int i = 0; i < 8; ++i) std::snprintf(hex + 8 * i, 9, "%08x", h_[i]);
  return std::string(hex, 64);
}

namespace {

// SHA-256 of what `in` yields, and its length in bytes.
std::string Digest(std::istream& in, std::int64_t& bytes) {
  Sha256 sha;
  std::array<char, 1 << 16> chunk;
  bytes = 0;
  while (in) {
    in.read(chunk.data(), chunk.size());
    sha.Update(chunk.data(), static_cast<std::size_t>(in.gcount()));
    bytes += in.gcount();
  }
  return sha.HexDigest();
}

}  // namespace

std::string Sha256Hex(std::istream& in) {
  std::int64_t bytes = 0;
  return Digest(in, bytes);
}

namespace {

// Size and SHA-256 of each readable regular file of `sources` (empty and
// repeated paths left out; one that cannot be read kept with size -1).
std::vector<SourceFile> HashSources(const std::vector<std::string>& sources) {
  std::vector<SourceFile> out;
  std::set<std::string> seen;
  for (const std::string& path : sources) {
    if (path.empty() || path == "-" || !seen.insert(path).second) continue;
    SourceFile s{WithPathsShown(path), -1, ""};  // standard input's copy: <stdin>
    std::error_code ec;
    // A device or a pipe is not hashed (it may never end): kept as not read.
    const bool regular = std::filesystem::is_regular_file(path, ec);
    std::ifstream in;
    if (regular) in.open(path, std::ios::binary);
    if (regular && in) {
      std::int64_t size = 0;
      std::string hex = Digest(in, size);
      if (!in.bad()) {
        s.size_bytes = size;
        s.sha256 = std::move(hex);
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

// What says that a file is as it was when hashed: its size and time of
// last change (-1 and the epoch when it cannot be read).
std::pair<std::int64_t, std::filesystem::file_time_type> FileStamp(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return {-1, {}};
  const auto time = std::filesystem::last_write_time(path, ec);
  if (ec) return {-1, {}};
  return {static_cast<std::int64_t>(size), time};
}

Provenance ProvenanceHeader() {
  Provenance p;
  p.rocklab_version = ROCKLAB_VERSION;
  p.build_type = ROCKLAB_BUILD_TYPE;
  p.command = ThisCommandLine();
  p.created_utc = NowUtc();
  return p;
}

}  // namespace

Provenance MakeProvenance(const std::vector<std::string>& sources) {
  Provenance p = ProvenanceHeader();
  p.sources = HashSources(sources);
  return p;
}

ProvenanceInBackground::ProvenanceInBackground(std::vector<std::string> sources) : paths_(std::move(sources)) {
  // The stamps before the hash: a file changed while it was hashed differs at Finish.
  for (const std::string& path : paths_) stamps_.push_back(FileStamp(path));
  hashed_ = std::async(std::launch::async, [paths = paths_] { return HashSources(paths); });
}

ProvenanceInBackground::~ProvenanceInBackground() {
  if (hashed_.valid()) hashed_.wait();
}

Provenance ProvenanceInBackground::Finish() {
  Provenance p = ProvenanceHeader();
  p.sources = hashed_.get();
  bool changed = false;
  for (std::size_t i = 0; i < paths_.size(); ++i) changed = changed || FileStamp(paths_[i]) != stamps_[i];
  if (changed) p.sources = HashSources(paths_);  // as MakeProvenance now would see them
  return p;
}

std::string ProvenanceJson(const Provenance& p) {
  nlohmann::ordered_json j;
  j["rocklab_version"] = p.rocklab_version;
  j["build_type"] = p.build_type;
  j["command"] = p.command;
  j["created_utc"] = p.created_utc;
  j["sources"] = nlohmann::ordered_json::array();
  for (const SourceFile& s : p.sources) {
    j["sources"].push_back({{"path", s.path}, {"size_bytes", s.size_bytes}, {"sha256", s.sha256}});
  }
  // Paths and arguments are bytes: invalid UTF-8 is replaced, not thrown.
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

std::string ProvenanceCommentLines(const std::vector<std::pair<std::string, std::string>>& fields,
                                   const std::string& title) {
  if (fields.empty()) return {};
  std::string out = "# " + title + "\n";
  for (const auto& [key, value] : fields) {
    std::string line = "# provenance." + key + ": " + value;
    for (char& c : line) {
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    }
    out += line + "\n";
  }
  return out;
}

std::string ProvenanceSidecarPath(const std::string& csv_path) {
  const bool csv = csv_path.size() >= 4 && csv_path.compare(csv_path.size() - 4, 4, ".csv") == 0;
  return (csv ? csv_path.substr(0, csv_path.size() - 4) : csv_path) + ".provenance.csv";
}

void WriteProvenanceSidecar(const std::string& csv_path, const std::vector<std::string>& sources) {
  if (csv_path.empty() || csv_path == "-") return;
  WriteProvenanceSidecarFields(csv_path, ProvenanceFields(MakeProvenance(sources)));
}

void WriteProvenanceSidecarFields(const std::string& csv_path,
                                  const std::vector<std::pair<std::string, std::string>>& fields) {
  if (csv_path.empty() || csv_path == "-") return;
  const auto quoted = [](const std::string& s) {
    std::string out = "\"";
    for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
  };
  std::string text = "key,value\n";
  for (const auto& [key, value] : fields) {
    text += quoted(key) + "," + quoted(value) + "\n";
  }
  AtomicFile out(ProvenanceSidecarPath(csv_path));
  if (std::fwrite(text.data(), 1, text.size(), out.stream()) != text.size()) {
    throw std::runtime_error("cannot write '" + out.target() + "'");
  }
  out.Commit();
}

std::uint32_t PngCrc32(const void* data, std::size_t bytes) {
  std::uint32_t crc = 0xFFFFFFFFu;
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    crc ^= p[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

namespace {

// XmlText, with control bytes (not allowed in XML 1.0 text) as spaces.
std::string XmlEscapedProvenance(const std::string& s) {
  std::string plain = s;
  for (char& c : plain) {
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
  }
  return XmlText(plain);
}

void PutBigEndian32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((v >> shift) & 0xFFu);
}

}  // namespace

bool AddProvenanceToFigure(const std::string& path, const std::vector<std::pair<std::string, std::string>>& fields) {
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read '" + path + "' to write its provenance");
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  static const std::string kPngSignature("\x89PNG\r\n\x1a\n", 8);
  if (bytes.compare(0, kPngSignature.size(), kPngSignature) == 0) {
    // The IEND chunk: its length (0), type, CRC are the file's last 12 bytes.
    if (bytes.size() < kPngSignature.size() + 12 || bytes.compare(bytes.size() - 8, 4, "IEND") != 0) return false;
    std::string chunks;
    for (const auto& [key, value] : fields) {
      const std::string keyword = key.rfind("rocklab_", 0) == 0 ? key : "rocklab_" + key;
      std::string body = "tEXt" + keyword.substr(0, 79) + std::string(1, '\0') + value;
      PutBigEndian32(chunks, static_cast<std::uint32_t>(body.size() - 4));
      chunks += body;
      PutBigEndian32(chunks, PngCrc32(body.data(), body.size()));
    }
    bytes.insert(bytes.size() - 12, chunks);
  } else {
    const std::size_t svg = bytes.find("<svg");
    const std::size_t open_end = svg == std::string::npos ? svg : bytes.find('>', svg);
    if (open_end == std::string::npos) return false;
    std::string meta = "\n<metadata>\n";
    for (const auto& [key, value] : fields) {
      meta += "  <rocklab:provenance xmlns:rocklab=\"https://rocklab.invalid/provenance\" key=\"" +
              XmlEscapedProvenance(key) + "\">" + XmlEscapedProvenance(value) + "</rocklab:provenance>\n";
    }
    meta += "</metadata>";
    bytes.insert(open_end + 1, meta);
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw std::runtime_error("cannot write the provenance into '" + path + "'");
  return true;
}

std::vector<std::pair<std::string, std::string>> ProvenanceFields(const Provenance& p) {
  std::vector<std::pair<std::string, std::string>> out = {{"rocklab_version", p.rocklab_version},
                                                          {"build_type", p.build_type},
                                                          {"command", p.command},
                                                          {"created_utc", p.created_utc}};
  for (const SourceFile& s : p.sources) {
    out.emplace_back("source_" + std::to_string(out.size() - 3), s.size_bytes < 0 ? s.path + " (could not be read)"
                                                : s.path + " (" + std::to_string(s.size_bytes) +
                                                      " bytes, sha256 " + s.sha256 + ")");
  }
  return out;
}

}  // namespace rocklab::common
