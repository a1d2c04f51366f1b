// rocklab_bench_log_read LOG: the raw cost of reading an LCM log with
// common::LogReader (every event, no decoding, no publishing): the floor that
// `rocklab replay LOG --max` is compared with in bench/run.sh. Prints
// "events bytes" on stdout.
#include <cstdint>
#include <cstdio>
#include <exception>

#include "common/lcm_log.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: rocklab_bench_log_read LOG\n");
    return 2;
  }
  try {
    rocklab::common::LogReader reader(argv[1]);
    rocklab::common::LogEvent event;
    std::int64_t events = 0, bytes = 0;
    while (reader.Next(event)) {
      ++events;
      bytes += static_cast<std::int64_t>(event.data.size());
    }
    std::printf("%lld %lld\n", static_cast<long long>(events), static_cast<long long>(bytes));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rocklab_bench_log_read: %s\n", e.what());
    return 1;
  }
  return 0;
}
