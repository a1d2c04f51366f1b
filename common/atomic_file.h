#pragma once
/// @file
/// Files that appear whole under their name or not at all.
///
/// An AtomicFile is written under a temporary name beside its target
/// (`TARGET.tmp-XXXXXX`: the same folder, so the rename cannot cross file
/// systems), and Commit() syncs it to disk and renames it over the target.
/// Destroyed without Commit() (an exception, a failed input, an early
/// return), it removes its temporary and the target keeps whatever it held
/// before. A killed process leaves at most a `TARGET.tmp-PID-XXXXXX` file
/// beside the target, never a torn file under the target's name; the next
/// AtomicFile of the same target removes such leftovers of processes that
/// no longer run (the PID in the name says whose it is).
///
/// The temporary is created empty at construction (mode 0666 less the
/// umask, as fopen would); write it through stream() or have a library
/// (HDF5, matio, gnuplot) open path() itself.

#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace rocklab::common {

class AtomicFile {
 public:
  /// Creates the temporary beside `target`; `temp_suffix` ends its name
  /// (`TARGET.tmp-PID-XXXXXX.mkv`: for a library that picks the format by
  /// the name's extension, as FFmpeg's muxers do).
  /// @throws std::runtime_error naming `target` when it cannot.
  explicit AtomicFile(std::string target, std::string_view temp_suffix = {});
  /// Removes the temporary unless committed.
  ~AtomicFile();
  AtomicFile(AtomicFile&& other) noexcept;
  AtomicFile& operator=(AtomicFile&&) = delete;
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The temporary's name: where to write.
  const std::string& path() const { return temp_; }
  /// The name the file gets at Commit().
  const std::string& target() const { return target_; }
  /// A stdio stream on the temporary (opened once, 64 KiB buffer), owned
  /// here and closed by Finish().
  /// @throws std::runtime_error naming the target.
  std::FILE* stream();

  /// Closes the stream (checking that every write succeeded) and syncs the
  /// temporary to disk; idempotent. After it only the rename is left.
  /// @throws std::runtime_error naming the target.
  void Finish();
  /// Finish(), then renames the temporary over the target and syncs the
  /// folder. @throws std::runtime_error naming the target (the temporary is
  /// then removed, the target untouched).
  void Commit();
  bool committed() const { return committed_; }

 private:
  void Discard() noexcept;

  std::string target_;
  std::string temp_;
  int fd_{-1};
  std::FILE* stream_{};
  bool finished_{false};
  bool committed_{false};
};

/// Commits `files` together: every one is finished (written and synced)
/// before the first is renamed, so a failure in any leaves every target as
/// it was. @throws std::runtime_error naming the file that failed.
void CommitAll(const std::vector<AtomicFile*>& files);

/// `text` into `path` through an AtomicFile.
/// @throws std::runtime_error naming `path`.
void WriteFileAtomically(const std::string& path, std::string_view text);

/// Syncs `temp` (a file this process wrote and closed) to disk and renames
/// it over `target`, then syncs the folder: the commit of a temporary with
/// a fixed name (a sweep's `--resume`able `.partial`).
/// @throws std::runtime_error naming `target`.
void CommitRename(const std::string& temp, const std::string& target);

}  // namespace rocklab::common
