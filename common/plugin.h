#pragma once
/// @file
/// rocklab's plugins: shared objects that the `rocklab` command opens
/// (dlopen) only when a command needs them, so that every other command
/// starts without their libraries (docs/architecture.md, "Plugins";
/// docs/performance.md, "Start-up"). They live in lib/rocklab/plugins/
/// beside the program's bin/ folder: /usr/lib/rocklab/plugins/ for
/// /usr/bin/rocklab, and build/lib/rocklab/plugins/ for build/tools/rocklab
/// in the build tree.
///
/// A plugin exports one C function, its entry, returning a table of
/// function pointers whose first member is the interface's version; it is
/// built from the same sources as the command, so the table's C++ types are
/// the command's.

#include <mutex>
#include <string>

namespace rocklab::common {

/// Where plugins are looked for: lib/rocklab/plugins in the parent of the running
/// program's folder (/proc/self/exe, links resolved).
std::string PluginDirectory();

/// The path PluginDirectory() gives `file` ("rocklab-video.so").
std::string PluginPath(const std::string& file);

/// What opening a plugin gave.
struct PluginLoad {
  void* entry{};      ///< the entry function's address; nullptr when it failed
  std::string path;   ///< the file tried
  std::string error;  ///< dlopen's or dlsym's message when entry is nullptr
};

/// Whether `file` is in PluginDirectory() (nothing is opened).
bool PluginInstalled(const std::string& file);

/// Opens `file` from PluginDirectory() and finds `entry_symbol` in it.
/// `global`: the plugin's symbols (and its libraries') visible to libraries
/// loaded after it (OpenMPI opens its own components and wants that).
/// A plugin once opened stays open for the life of the process.
PluginLoad LoadPlugin(const std::string& file, const char* entry_symbol, bool global = false);

/// LoadPlugin, then the entry called (`const Calls* entry()`): its table
/// when the table's `version` member is `version`; else nullptr, and
/// `error` says why (the file missing, dlopen's message, another version).
template <typename Calls>
const Calls* OpenPlugin(const std::string& file, const char* entry_symbol, int version, std::string& error,
                        bool global = false) {
  const PluginLoad load = LoadPlugin(file, entry_symbol, global);
  if (load.entry == nullptr) {
    error = load.error;
    return nullptr;
  }
  const Calls* calls = reinterpret_cast<const Calls* (*)()>(load.entry)();
  if (calls == nullptr || calls->version != version) {
    error = load.path + ": a plugin of another rocklab version (interface " +
            (calls == nullptr ? std::string("none") : std::to_string(calls->version)) + ", this rocklab's " +
            std::to_string(version) + ")";
    return nullptr;
  }
  return calls;
}

/// OpenPlugin once for the process, per table type: the first call opens,
/// later ones give its result (the table, or nullptr and the same `error`).
template <typename Calls>
const Calls* OpenPluginOnce(const std::string& file, const char* entry_symbol, int version, std::string& error,
                            bool global = false) {
  static const Calls* calls = nullptr;
  static std::string why;
  static std::once_flag once;
  std::call_once(once, [&] { calls = OpenPlugin<Calls>(file, entry_symbol, version, why, global); });
  if (calls == nullptr) error = why;
  return calls;
}

}  // namespace rocklab::common
