// The command's start-up (issue 33, docs/performance.md "Start-up"): what
// `rocklab --version` and `rocklab simulate --help` load, counted (a
// number, not a time), and the plugins: video and MPI are not loaded by
// them, nor the monitor's HTTP server (libmicrohttpd, gnutls), `--version`
// says which parts are there, and a rocklab without its video or monitor
// plugin names the package to install.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "tests/scratch.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

// What the dynamic linker said of its files (LD_DEBUG=files) while
// `binary args` ran, which must exit 0: one "file=NAME [0];  generating
// link map" per object loaded, also for dlopen() ("dynamically loaded by").
std::string LdDebugFiles(const std::string& binary, const std::string& args) {
  const std::string dir = ScratchDir("startup");
  const std::string log = dir + "/ld_debug";
  const std::string command = "LD_DEBUG=files LD_DEBUG_OUTPUT='" + log + "' '" + binary + "' " + args +
                              " > /dev/null 2>&1";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  std::string text;
  // LD_DEBUG_OUTPUT appends the process id to the file name.
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().rfind("ld_debug", 0) != 0) continue;
    text += Slurp(e.path().string());
    std::filesystem::remove(e.path());
  }
  return text;
}

// The shared objects the dynamic linker loaded while `binary args` ran, by name.
std::set<std::string> LoadedObjects(const std::string& binary, const std::string& args) {
  const std::string text = LdDebugFiles(binary, args);
  const std::regex loaded(R"(file=(\S+) \[\d+\];\s+generating link map)");
  std::set<std::string> names;
  std::smatch m;
  for (auto it = text.cbegin(); std::regex_search(it, text.cend(), m, loaded); it = m.suffix().first) {
    names.insert(m[1].str());
  }
  return names;
}

std::string Join(const std::set<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += n + "\n";
  return s;
}

// The bound: the shared objects `rocklab --version` and `rocklab simulate
// --help` load as measured on Debian bookworm, with room for two that a
// Debian update may add to a dependency's closure. With SUNDIALS linked
// statically (ROCKLAB_SUNDIALS_STATIC, the default where Debian ships its
// archives) 4: libstdc++, libm, libgcc_s, libc; with SUNDIALS' shared
// libraries 6, CVODE and ARKODE besides (docs/performance.md, Start-up).
// Before the plugins it was 259 (OpenCV's videoio 242 of them, HDF5 and
// matio 25, OpenMPI 6), then 22 with libmicrohttpd and its gnutls closure
// (10 objects), which only `monitor` needs, then 10 with liblcm (and its
// glib and pcre2), spdlog, fmt and toml++, which the command now opens when
// it opens the bus (tools/lcm_forward.cpp) or carries compiled in
// (tools/toml_implementation.cpp, tools/spdlog_fmt_implementation.cpp).
// (-DROCKLAB_COMMAND_OWN_LIBS=OFF, the sanitizer pass: spdlog, fmt and
// toml++ linked as shared libraries, 3 more.)
#ifdef ROCKLAB_SUNDIALS_STATIC
constexpr std::size_t kSundialsObjects = 0;
#else
constexpr std::size_t kSundialsObjects = 2;
#endif
#ifdef ROCKLAB_COMMAND_OWN_LIBS
constexpr std::size_t kMaxCoreObjects = 6 + kSundialsObjects;
#else
constexpr std::size_t kMaxCoreObjects = 9 + kSundialsObjects;
#endif
// Names that only the plugins may bring: OpenCV and what its videoio
// needs (FFmpeg, GStreamer, GDAL, poppler), OpenMPI, HDF5 and matio (and
// libcurl, which Debian's HDF5 brings), libmicrohttpd and its gnutls.
const std::regex kPluginOnly(
    R"(opencv|avcodec|avformat|gst|gdal|poppler|libmpi|open-pal|open-rte|hdf5|matio|curl|microhttpd|gnutls)");
// Names the command no longer loads at its start: liblcm (with glib and
// pcre2) is opened by the first bus, spdlog, fmt and toml++ are compiled in.
#ifdef ROCKLAB_COMMAND_OWN_LIBS
const std::regex kNotAtStart(R"(liblcm|libglib|libpcre|libspdlog|libfmt|libtomlplusplus)");
#else
const std::regex kNotAtStart(R"(liblcm|libglib|libpcre)");
#endif

TEST(Startup, VersionMapsTheCoreLibrariesOnly) {
  for (const std::string args : {"--version", "simulate --help"}) {
    const std::set<std::string> names = LoadedObjects(ROCKLAB_BINARY, args);
    ASSERT_FALSE(names.empty()) << "LD_DEBUG=files printed nothing for rocklab " << args;
    EXPECT_LE(names.size(), kMaxCoreObjects) << "rocklab " << args << " loads:\n" << Join(names);
    for (const std::string& n : names) {
      EXPECT_FALSE(std::regex_search(n, kPluginOnly)) << "rocklab " << args << " loads " << n;
      EXPECT_FALSE(std::regex_search(n, kNotAtStart)) << "rocklab " << args << " loads " << n;
      EXPECT_EQ(n.find("rocklab-"), std::string::npos) << "rocklab " << args << " opens the plugin " << n;
#ifdef ROCKLAB_SUNDIALS_STATIC
      EXPECT_EQ(n.find("libsundials"), std::string::npos) << "rocklab " << args << " maps " << n
                                                          << " though SUNDIALS is linked statically";
#endif
    }
  }
}

// The DAQ over memq:// (a recorded CSV as fast as it reads, then it ends):
// it publishes on the bus, so it opens liblcm. Its arguments.
std::string DaqOverMemqArgs() {
  return "daq --rig '" + std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml' --input '" +
         ROCKLAB_SOURCE_DIR + "/data/samples/free_rocking.csv' --max --lcm-url memq://";
}

// The bus opens liblcm when a command first asks for it (LD_DEBUG=files
// sees the dlopen); a command without a bus never does.
TEST(Startup, TheBusLoadsLiblcmWhenOpened) {
  const std::set<std::string> names =
      LoadedObjects(ROCKLAB_BINARY, "info '" + std::string(ROCKLAB_SOURCE_DIR) + "/data/samples/fig7_block1.csv'");
  for (const std::string& n : names) EXPECT_EQ(n.find("liblcm"), std::string::npos) << "info loads " << n;
  const std::string loaded = LdDebugFiles(ROCKLAB_BINARY, DaqOverMemqArgs());
  EXPECT_NE(loaded.find("file=liblcm.so.1 [0];  dynamically loaded by"), std::string::npos) << loaded;
}

// A liblcm that is not LCM (an empty shared object named liblcm.so.1, first
// on LD_LIBRARY_PATH): the bus is refused with a message naming the library
// and the package, and the command ends with an error, not a crash.
TEST(Startup, ABrokenLiblcmIsNamedWithItsPackage) {
  const std::string dir = ScratchDir("startup_no_lcm");
  const std::string command = "LD_LIBRARY_PATH='" + std::string(ROCKLAB_NOT_LIBLCM_DIR) + "' '" +
                              std::string(ROCKLAB_BINARY) + "' " + DaqOverMemqArgs() + " > '" + dir + "/out' 2> '" +
                              dir + "/err'";
  const int status = std::system(command.c_str());
  const std::string err = Slurp(dir + "/err");
  ASSERT_TRUE(WIFEXITED(status)) << command << "\n" << err;
  EXPECT_NE(WEXITSTATUS(status), 0) << err;
  EXPECT_NE(err.find("the LCM bus needs liblcm.so.1, which does not load: liblcm.so.1 has no lcm_create"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("apt-get install liblcm1"), std::string::npos) << err;
  EXPECT_NE(err.find("cannot open LCM at 'memq://'"), std::string::npos) << err;
  // simulate needs no bus, so no liblcm either.
  const std::string sim = "LD_LIBRARY_PATH='" + std::string(ROCKLAB_NOT_LIBLCM_DIR) + "' '" +
                          std::string(ROCKLAB_BINARY) + "' simulate --alpha 0.2 --p 2 --mu 0.9 --rate 100 --duration 1 --out - > /dev/null";
  EXPECT_EQ(std::system(sim.c_str()), 0) << sim;
}

TEST(Startup, VersionSaysBuildTypeAndParts) {
  const CliResult r = RunCli({"--version"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("rocklab 0.1.0\n", 0), 0u) << r.out;  // the first line as before
  EXPECT_NE(r.out.find("\nbuild: "), std::string::npos) << r.out;
  for (const char* part : {"\nvideo ", "\nMPI ", "\nHDF5 ", "\nMATLAB ", "\nmonitor ", "\nPython "}) {
    EXPECT_NE(r.out.find(part), std::string::npos) << part << " missing from\n" << r.out;
  }
  EXPECT_NE(r.out.find("libmicrohttpd): installed ("), std::string::npos) << r.out;
  const CliResult loaded = RunCli({"--version", "--load"});
  ASSERT_EQ(loaded.exit_code, 0) << loaded.err;
  EXPECT_NE(loaded.out.find("libmicrohttpd): loads ("), std::string::npos) << loaded.out;
#ifdef ROCKLAB_HAVE_VIDEO
  EXPECT_NE(r.out.find("camera-calibrate): installed ("), std::string::npos) << r.out;
  const CliResult load = RunCli({"--version", "--load"});
  ASSERT_EQ(load.exit_code, 0) << load.err;
  EXPECT_NE(load.out.find("camera-calibrate): loads ("), std::string::npos) << load.out;
#endif
#ifdef ROCKLAB_HAVE_MPI
  EXPECT_NE(r.out.find("sweep): installed ("), std::string::npos) << r.out;
  const CliResult mpi = RunCli({"--version", "--load"});
  EXPECT_NE(mpi.out.find("sweep): loads ("), std::string::npos) << mpi.out;
#endif
}

// `rocklab COMMAND ...` registers that command alone (tools/main.cpp),
// `rocklab help COMMAND` every command. Oracle: the latter, for every
// command `rocklab help` lists: each command's --help is the same text
// (but for the program's name on its usage line, argv[0] there), so the
// one command registered is the command asked for, with all its options.
TEST(Startup, ACommandAloneHasTheSameHelpAsAmongAll) {
  const CliResult list = RunCli({"help"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  std::vector<std::string> names;
  const std::regex line(R"(\n  ([a-z][a-z0-9-]*)  )");
  for (std::sregex_iterator it(list.out.begin(), list.out.end(), line), end; it != end; ++it) {
    names.push_back((*it)[1].str());
  }
  ASSERT_GE(names.size(), 20u) << list.out;
  const std::regex usage(R"(Usage: \S*rocklab )");
  for (const std::string& name : names) {
    const CliResult all = RunCli({"help", name});
    const CliResult alone = RunCli({name, "--help"});
    ASSERT_EQ(all.exit_code, 0) << name << ": " << all.err;
    ASSERT_EQ(alone.exit_code, 0) << name << ": " << alone.err;
    EXPECT_EQ(std::regex_replace(alone.out, usage, "Usage: rocklab "), all.out) << name;
  }
}

// The binary alone in dir/bin, with no lib/rocklab/plugins beside it: a
// rocklab whose plugins are not installed.
std::string CopyWithoutPlugins(const std::string& dir) {
  std::filesystem::create_directories(dir + "/bin");
  const std::string bin = dir + "/bin/rocklab";
  std::filesystem::copy_file(ROCKLAB_BINARY, bin, std::filesystem::copy_options::overwrite_existing);
  return bin;
}

// Without its plugin, `monitor` fails as a command that cannot run (1),
// before it opens the bus or binds, naming the file and the package; the
// bad options are still usage errors (2); other commands run.
TEST(Startup, WithoutTheMonitorPluginNamesThePackage) {
  const std::string dir = ScratchDir("no_monitor");
  const std::string bin = CopyWithoutPlugins(dir);
  const std::string err = dir + "/err";
  int status = std::system(("'" + bin + "' monitor --lcm-url memq:// --http 127.0.0.1:0 > /dev/null 2> '" + err +
                            "'")
                               .c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string text = Slurp(err);
  EXPECT_NE(text.find("the monitor's HTTP server is the plugin " + dir + "/lib/rocklab/plugins/rocklab-monitor.so" +
                      ", which is missing: the package rocklab installs it (apt-get install --reinstall rocklab)"),
            std::string::npos)
      << text;
  status = std::system(("'" + bin + "' monitor --http nohost > /dev/null 2> '" + err + "'").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2) << Slurp(err);
  EXPECT_EQ(std::system(("'" + bin + "' --version > '" + dir + "/v.out'").c_str()), 0);
  const std::string version = Slurp(dir + "/v.out");
  EXPECT_NE(version.find("libmicrohttpd): not installed (" + dir + "/lib/rocklab/plugins/rocklab-monitor.so missing"),
            std::string::npos)
      << version;
}

#ifdef ROCKLAB_HAVE_VIDEO
// A rocklab installed without rocklab-video: the binary alone in a bin/
// folder with no lib/rocklab/plugins beside it.
TEST(Startup, WithoutTheVideoPluginNamesThePackage) {
  const std::string dir = ScratchDir("no_video");
  const std::string bin = CopyWithoutPlugins(dir);
  const std::string rig = std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml";
  // The two video commands fail as a command that cannot run (1); an
  // input that cannot be opened is reconstruct's usage error (2), as a
  // missing file is.
  const std::vector<std::pair<std::string, int>> commands = {
      {"'" + bin + "' track video.mp4 --rig '" + rig + "' --out '" + dir + "/t.csv'", 1},
      {"'" + bin + "' camera-calibrate board.mp4 --out '" + dir + "/cam.toml'", 1},
      {"'" + bin + "' reconstruct --rig '" + rig + "' --input video:video.mp4 --out '" + dir + "/r.csv'", 2},
  };
  for (const auto& [c, code] : commands) {
    const std::string err = dir + "/err";
    const int status = std::system((c + " > /dev/null 2> '" + err + "'").c_str());
    ASSERT_TRUE(WIFEXITED(status)) << c;
    EXPECT_EQ(WEXITSTATUS(status), code) << c;
    const std::string text = Slurp(err);
    EXPECT_NE(text.find("package rocklab-video, which is not installed (apt-get install rocklab-video"),
              std::string::npos)
        << c << ": " << text;
    EXPECT_NE(text.find(dir + "/lib/rocklab/plugins/rocklab-video.so"), std::string::npos) << c << ": " << text;
  }
  // Everything else runs.
  const int status = std::system(("'" + bin + "' simulate --model housner --alpha 0.235 --p 3.884 --mu 0.937 " +
                                  "--theta0 0.1175 --duration 1 --rate 100 --out '" + dir + "/theta.csv' > /dev/null 2> '" +
                                  dir + "/sim.err'")
                                     .c_str());
  EXPECT_EQ(status, 0) << Slurp(dir + "/sim.err");
  EXPECT_EQ(std::system(("'" + bin + "' --version > '" + dir + "/v.out'").c_str()), 0);
  const std::string version = Slurp(dir + "/v.out");
  EXPECT_NE(version.find("not installed (apt-get install rocklab-video)"), std::string::npos) << version;
}
#endif

}  // namespace
}  // namespace rocklab::test
