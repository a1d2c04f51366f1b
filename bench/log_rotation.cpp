// The writing thread's time in RotatingLogWriter::Write with a provenance
// sidecar attached (docs/performance.md, "A log's rotation on the DAQ's
// thread"): every write, and the writes that rotated the file.
//
//   rocklab_bench_log_rotation [SOURCE_MB] [EVENTS] [DIR]
//
// The source (SOURCE_MB of bytes, hashed for the sidecars) and the log
// series are written under DIR (default /tmp/rocklab_bench_log_rotation).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "record/log_provenance.h"
#include "record/log_writer.h"

int main(int argc, char** argv) {
  using rocklab::record::LogProvenance;
  using rocklab::record::RotatingLogWriter;
  using rocklab::record::RotationOptions;
  const int source_mb = argc > 1 ? std::atoi(argv[1]) : 200;
  const int events = argc > 2 ? std::atoi(argv[2]) : 20000;
  const std::filesystem::path dir = argc > 3 ? argv[3] : "/tmp/rocklab_bench_log_rotation";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string source = (dir / "source.bin").string();
  {
    std::ofstream f(source, std::ios::binary);
    const std::string mb(1 << 20, 'x');
    for (int i = 0; i < source_mb; ++i) f << mb;
  }
  RotationOptions o;
  o.path = (dir / "log.lcm").string();
  o.rotate_bytes = 200000;  // a file per ~190 events of 1 kB
  o.overwrite = true;
  LogProvenance provenance({source}, {{"rig", "bench"}});
  provenance.Attach(o);
  RotatingLogWriter w(o);
  const std::vector<uint8_t> data(1000, 7);
  std::vector<double> rotations_us, writes_us;
  writes_us.reserve(static_cast<std::size_t>(events));
  std::size_t files = 1;
  for (int i = 0; i < events; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    if (!w.Write(1'000'000 + int64_t{i} * 1000, "RL_BENCH", data.data(), static_cast<uint32_t>(data.size()))) {
      std::fprintf(stderr, "write failed: %s\n", w.error().c_str());
      return 1;
    }
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    writes_us.push_back(us);
    if (w.files().size() != files) {
      files = w.files().size();
      rotations_us.push_back(us);
    }
  }
  if (!w.Close()) return 1;
  const long long errors = provenance.errors();
  if (rotations_us.empty()) return 1;
  std::sort(rotations_us.begin(), rotations_us.end());
  std::sort(writes_us.begin(), writes_us.end());
  std::printf("%zu rotations: median %.1f us, max %.1f us; %d writes: p99 %.2f us, max %.1f us; sidecar errors %lld\n",
              rotations_us.size(), rotations_us[rotations_us.size() / 2], rotations_us.back(), events,
              writes_us[writes_us.size() * 99 / 100], writes_us.back(), errors);
  std::filesystem::remove_all(dir);
  return errors == 0 ? 0 : 1;
}
