#pragma once
/// @file
/// Provenance of the files rocklab writes: which rocklab (version, build
/// type) made it, by which command line, when (UTC), and from which files
/// (path, size, SHA-256), so a result can be traced to its inputs and
/// checked against them (`sha256sum FILE`). docs/provenance.md says where
/// each kind of output keeps it.

#include <cstdint>
#include <ctime>
#include <filesystem>
#include <future>
#include <istream>
#include <string>
#include <utility>
#include <vector>

namespace rocklab::common {

/// SHA-256 (FIPS 180-4) of a byte stream, as 64 lowercase hex digits.
class Sha256 {
 public:
  /// kFastest: the x86 SHA extensions where the CPU has them, else the
  /// portable rounds; kPortable: the portable rounds always (the tests
  /// hold both paths to the same digests).
  enum class Rounds { kFastest, kPortable };
  explicit Sha256(Rounds rounds = Rounds::kFastest);
  void Update(const void* data, std::size_t bytes);
  /// The digest; the object is spent afterwards.
  std::string HexDigest();
  /// Whether this CPU has the SHA extensions kFastest uses.
  static bool CpuHasShaExtensions();

 private:
  void Block(const unsigned char* p);
  bool extensions_{false};
  std::uint32_t h_[8];
  unsigned char buffer_[64];
  std::size_t buffered_{};
  std::uint64_t total_bytes_{};
};

/// SHA-256 of everything `in` yields.
std::string Sha256Hex(std::istream& in);

struct SourceFile {
  std::string path;          ///< as given on the command line
  std::int64_t size_bytes{};  ///< -1: could not be read (then sha256 is empty)
  std::string sha256;         ///< hex
};

struct Provenance {
  std::string rocklab_version;  ///< "0.1.0"
  std::string build_type;       ///< CMake's (RelWithDebInfo, Release, ...)
  std::string command;          ///< the process's command line, arguments shell-quoted
  std::string created_utc;      ///< ISO 8601, e.g. 2026-11-26T22:40:00Z
  std::vector<SourceFile> sources;
};

/// `time` as created_utc writes it (ISO 8601 in UTC, to the second).
std::string UtcText(std::time_t time);

/// The provenance of a file made now from `sources` (read and hashed here;
/// a path that is empty or repeated is left out, one that cannot be read
/// is kept with size -1). The command line is this process's
/// (/proc/self/cmdline: the `rocklab` command, or the python3 running the
/// module).
Provenance MakeProvenance(const std::vector<std::string>& sources);

/// MakeProvenance(sources) with the files hashed on a thread of its own
/// from construction on, while the command goes on (`run` hashes a 109 MB
/// input in ~1 s: docs/performance.md, "Issue 33, third round"). Finish()
/// returns what MakeProvenance(sources) would return then: the command
/// line and time of that moment, and every file hashed again whose size or
/// time of last change moved since construction.
class ProvenanceInBackground {
 public:
  explicit ProvenanceInBackground(std::vector<std::string> sources);
  ~ProvenanceInBackground();  ///< waits for the hashing thread
  ProvenanceInBackground(const ProvenanceInBackground&) = delete;
  ProvenanceInBackground& operator=(const ProvenanceInBackground&) = delete;
  /// Once only.
  Provenance Finish();

 private:
  std::vector<std::string> paths_;
  std::vector<std::pair<std::int64_t, std::filesystem::file_time_type>> stamps_;
  std::future<std::vector<SourceFile>> hashed_;
};

/// One JSON object: rocklab_version, build_type, command, created_utc,
/// sources ([{path, size_bytes, sha256}]).
std::string ProvenanceJson(const Provenance& p);

/// The same as flat text pairs, for formats with text attributes (HDF5
/// attributes, `# key: value` lines): rocklab_version, build_type,
/// command, created_utc, then `source_1`, `source_2`, ... one per file, as
/// "PATH (SIZE bytes, sha256 HEX)" (keys unique: HDF5 attribute names).
std::vector<std::pair<std::string, std::string>> ProvenanceFields(const Provenance& p);

/// `fields` as comment lines of a text format whose readers skip `#` lines
/// (a sweep's results, a TOML file): `# TITLE`, then one
/// `# provenance.KEY: value` per field (a control character in a line
/// written `?`, so each stays one line). Empty for no fields.
std::string ProvenanceCommentLines(const std::vector<std::pair<std::string, std::string>>& fields,
                                   const std::string& title);

/// The provenance sidecar of a CSV file: `STEM.provenance.csv` beside
/// `STEM.csv` (any other name: NAME.provenance.csv), as `export` writes it.
std::string ProvenanceSidecarPath(const std::string& csv_path);

/// Writes ProvenanceFields(MakeProvenance(sources)) beside `csv_path` (at
/// ProvenanceSidecarPath): header `key,value`, one row per field, both
/// fields double-quoted (a quote doubled), written whole (AtomicFile).
/// The CSV's own bytes are untouched, so every reader of it reads it as
/// before. Nothing for "" or "-" (standard output).
/// @throws std::runtime_error naming the sidecar when it cannot be written.
void WriteProvenanceSidecar(const std::string& csv_path, const std::vector<std::string>& sources);
/// The same with the fields made already (ProvenanceFields).
void WriteProvenanceSidecarFields(const std::string& csv_path,
                                  const std::vector<std::pair<std::string, std::string>>& fields);

/// Writes `fields` into the figure at `path`, in place, where its format
/// keeps text without changing the picture: an SVG gets a `<metadata>`
/// element right after its `<svg ...>` start tag holding one
/// `<rocklab:provenance key="..">value</rocklab:provenance>` per field
/// (XML-escaped); a PNG one tEXt chunk per field (keyword
/// `rocklab_KEY`, or KEY when it starts so, text as bytes; PNG 1.2: keyword 1-79 Latin-1
/// characters) before its IEND chunk. Anything else is left as it is.
/// @returns false when the file is neither (nothing written).
/// @throws std::runtime_error naming the file when it cannot be read or written.
bool AddProvenanceToFigure(const std::string& path, const std::vector<std::pair<std::string, std::string>>& fields);

/// CRC-32 of PNG chunks (ISO 3309 / ITU-T V.42, reflected 0xEDB88320).
std::uint32_t PngCrc32(const void* data, std::size_t bytes);

}  // namespace rocklab::common
