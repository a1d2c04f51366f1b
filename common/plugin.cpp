#include "common/plugin.h"

#include <dlfcn.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace rocklab::common {
namespace {

// The running program's folder, from /proc/self/exe (argv[0] may be a bare
// name found on PATH); "." when it cannot be read.
std::string ProgramFolder() {
  std::vector<char> buffer(4096);
  const ssize_t n = readlink("/proc/self/exe", buffer.data(), buffer.size() - 1);
  if (n <= 0) return ".";
  const std::string path(buffer.data(), static_cast<std::size_t>(n));
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

}  // namespace

std::string PluginDirectory() {
  // bin/rocklab -> lib/rocklab/plugins (build/tools/rocklab -> build/lib/rocklab/plugins).
  const std::string folder = ProgramFolder();
  const std::size_t slash = folder.rfind('/');
  if (slash == std::string::npos) return folder + "/../lib/rocklab/plugins";
  return folder.substr(0, slash) + "/lib/rocklab/plugins";
}

std::string PluginPath(const std::string& file) { return PluginDirectory() + "/" + file; }

bool PluginInstalled(const std::string& file) { return access(PluginPath(file).c_str(), F_OK) == 0; }

PluginLoad LoadPlugin(const std::string& file, const char* entry_symbol, bool global) {
  PluginLoad load;
  load.path = PluginPath(file);
  if (access(load.path.c_str(), F_OK) != 0) {
    load.error = load.path + ": no such file";
    return load;
  }
  dlerror();  // clear an older message
  void* handle = dlopen(load.path.c_str(), RTLD_NOW | (global ? RTLD_GLOBAL : RTLD_LOCAL));
  if (handle == nullptr) {
    const char* why = dlerror();
    load.error = why != nullptr ? why : (load.path + ": cannot be opened");
    return load;
  }
  load.entry = dlsym(handle, entry_symbol);
  if (load.entry == nullptr) {
    const char* why = dlerror();
    load.error = load.path + ": no " + entry_symbol + (why != nullptr ? std::string(" (") + why + ")" : "");
    dlclose(handle);
  }
  return load;
}

}  // namespace rocklab::common
