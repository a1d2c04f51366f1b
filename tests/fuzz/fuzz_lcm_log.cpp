// Fuzz target: the one LCM log reader (common::LogReader). Input: the bytes
// of a log file (held in a memfd: no disk traffic). The first byte, when the
// input is long enough, picks reader options (a channel filter, a window),
// so the window and filter paths are explored too.
// Invariants: opening throws only std::runtime_error (no readable event);
// afterwards nothing throws; every event delivered fits in the file (its
// header, channel and data within the file's size, channel within the
// option's bound); the counters add up (delivered + filtered +
// outside_window <= events; every damaged region reported once to the
// callback, with its bytes inside the file); Rewind and a second pass
// deliver the same events.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/lcm_log.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using rocklab::common::LogEvent;
using rocklab::common::LogProblem;
using rocklab::common::LogReader;
using rocklab::common::LogReaderOptions;
using rocklab::fuzz::Violated;

// A memfd holding `size` bytes; -1 when the system has none.
int MemFile(const std::uint8_t* data, std::size_t size) {
  const int fd = memfd_create("fuzz_lcm_log", MFD_CLOEXEC);
  if (fd < 0) return -1;
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n <= 0) {
      close(fd);
      return -1;
    }
    done += static_cast<std::size_t>(n);
  }
  return fd;
}

struct Pass {
  std::vector<std::int64_t> offsets;
  std::vector<std::string> channels;
  std::vector<std::size_t> sizes;
};

Pass ReadAll(LogReader& reader, std::int64_t file_size, const LogReaderOptions& o) {
  Pass p;
  LogEvent ev;
  while (reader.Next(ev)) {
    if (ev.offset < 0 || ev.channel.empty()) Violated("event offset or channel");
    if (static_cast<std::int64_t>(ev.channel.size()) > o.max_channel_bytes) Violated("channel over the bound");
    const std::int64_t end = ev.offset + 28 + static_cast<std::int64_t>(ev.channel.size()) +
                             static_cast<std::int64_t>(ev.data.size());
    if (end > file_size) Violated("event beyond the end of the file");
    if (!p.offsets.empty() && ev.offset <= p.offsets.back()) Violated("events not in file order");
    p.offsets.push_back(ev.offset);
    p.channels.push_back(ev.channel);
    p.sizes.push_back(ev.data.size());
  }
  return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  LogReaderOptions options;
  std::size_t skip = 0;
  if (size > 32 && (data[0] & 0x80) != 0) {
    // Options from the first byte; the log is the rest.
    skip = 1;
    if (data[0] & 1) options.channels = "RL_(THETA|TABLE|MODEL_.*)";
    if (data[0] & 2) options.start_s = 0.001 * (data[0] & 0x0c);
    if (data[0] & 0x10) options.end_s = 0.002 * ((data[0] >> 2) & 7);
    if (data[0] & 0x20) options.max_channel_bytes = 8;
    if (data[0] & 0x40) options.max_data_bytes = 64;
  }
  const int fd = MemFile(data + skip, size - skip);
  if (fd < 0) return 0;
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  const auto file_size = static_cast<std::int64_t>(size - skip);
  std::vector<LogProblem> problems;
  options.on_problem = [&problems](const LogProblem& p) { problems.push_back(p); };
  try {
    LogReader reader(path, options);
    const Pass first = ReadAll(reader, file_size, options);
    const auto counts = reader.counts();
    if (counts.delivered != static_cast<std::int64_t>(first.offsets.size())) Violated("delivered count");
    if (counts.delivered + counts.filtered + counts.outside_window > counts.events) Violated("event counts");
    if (counts.damaged_regions != static_cast<std::int64_t>(problems.size())) Violated("regions reported");
    std::int64_t bytes = 0;
    for (const LogProblem& p : problems) {
      if (p.offset < 0 || p.bytes <= 0 || p.offset + p.bytes > file_size) Violated("damaged region bounds");
      if (p.events < 1) Violated("damaged region with no event lost");
      rocklab::fuzz::CheckMessage(rocklab::common::ToString(p), 4096);
      bytes += p.bytes;
    }
    if (bytes != counts.damaged_bytes || bytes > file_size) Violated("damaged bytes");
    reader.Rewind();
    const Pass second = ReadAll(reader, file_size, options);
    if (second.offsets != first.offsets || second.channels != first.channels ||
        second.sizes != first.sizes) {
      Violated("a second pass delivered other events");
    }
    if (static_cast<std::int64_t>(problems.size()) != counts.damaged_regions) {
      Violated("a region reported twice");
    }
  } catch (const std::runtime_error& e) {
    rocklab::fuzz::CheckMessage(e.what(), 4096);
  }
  close(fd);
  return 0;
}
