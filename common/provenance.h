#pragma once
/// @file
/// Provenance of the files rocklab writes: which rocklab (version, build
/// type) made it, by which command line, when (UTC), and from which files
/// (path, size, SHA-256), so a result can be traced to its inputs and
/// checked against them (`sha256sum FILE`). docs/provenance.md says where
/// each kind of output keeps it.

#include <cstdint>
#include <istream>
#include <string>
#include <utility>
#include <vector>

namespace rocklab::common {

/// SHA-256 (FIPS 180-4) of a byte stream, as 64 lowercase hex digits.
class Sha256 {
 public:
  Sha256();
  void Update(const void* data, std::size_t bytes);
  /// The digest; the object is spent afterwards.
  std::string HexDigest();

 private:
  void Block(const unsigned char* p);
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

/// The provenance of a file made now from `sources` (read and hashed here;
/// a path that is empty or repeated is left out, one that cannot be read
/// is kept with size -1). The command line is this process's
/// (/proc/self/cmdline: the `rocklab` command, or the python3 running the
/// module).
Provenance MakeProvenance(const std::vector<std::string>& sources);

/// One JSON object: rocklab_version, build_type, command, created_utc,
/// sources ([{path, size_bytes, sha256}]).
std::string ProvenanceJson(const Provenance& p);

/// The same as flat text pairs, for formats with text attributes (HDF5
/// attributes, `# key: value` lines): rocklab_version, build_type,
/// command, created_utc, then `source_1`, `source_2`, ... one per file, as
/// "PATH (SIZE bytes, sha256 HEX)" (keys unique: HDF5 attribute names).
std::vector<std::pair<std::string, std::string>> ProvenanceFields(const Provenance& p);

}  // namespace rocklab::common
