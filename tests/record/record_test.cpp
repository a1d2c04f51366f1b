// rocklab::record: the queue, the LCM log writer and its rotation, and the
// recorder over memq://. The logs are read back with LCM's own reader
// (lcm::LogFile), an implementation independent of the writer.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "tests/scratch.h"
#include "record/event_queue.h"
#include "record/log_provenance.h"
#include "record/log_writer.h"
#include "record/recorder.h"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::record {
namespace {

struct Event {
  int64_t number{};
  int64_t utime{};
  std::string channel;
  std::string data;
};

// Every event of an LCM log, read by LCM's reader.
std::vector<Event> ReadLog(const std::string& path) {
  std::vector<Event> out;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  if (!log.good()) return out;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    out.push_back({ev->eventnum, ev->timestamp, ev->channel,
                   std::string(static_cast<const char*>(ev->data), static_cast<std::size_t>(ev->datalen))});
  }
  return out;
}

std::string Scratch(const std::string& name) {
  const std::string dir = test::ScratchDir("record");
  const std::string path = dir + "/" + name;
  ::unlink(path.c_str());
  return path;
}

std::string Payload(int i, std::size_t size) {
  std::string s(size, '\0');
  for (std::size_t k = 0; k < size; ++k) s[k] = static_cast<char>((i * 31 + static_cast<int>(k) * 7) & 0xFF);
  return s;
}

int64_t FileSize(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? st.st_size : -1;
}

// Oracle: FIFO order and content; a full queue refuses (and keeps what it
// holds) instead of blocking. Record size: 24 + channel + payload, 8-aligned.
TEST(EventQueueTest, RefusesWhenFullAndKeepsOrder) {
  EventQueue q(1024);
  ASSERT_EQ(EventQueue::RecordBytes(3, 100), 128u);
  int pushed = 0;
  while (q.Push(pushed, 1000 + pushed, "CH" + std::to_string(pushed % 10), Payload(pushed, 100).data(), 100)) {
    ++pushed;
  }
  EXPECT_EQ(pushed, 8);  // 8 x 128 bytes fill 1024
  EXPECT_FALSE(q.Push(99, 0, "X", "y", 1));
  std::vector<int> seen;
  const int n = q.PopBatch(
      [&](const EventView& ev) {
        EXPECT_EQ(ev.utime, 1000 + ev.channel_id);
        EXPECT_EQ(std::string(ev.channel), "CH" + std::to_string(ev.channel_id % 10));
        EXPECT_EQ(std::string(reinterpret_cast<const char*>(ev.data), ev.size), Payload(ev.channel_id, 100));
        seen.push_back(ev.channel_id);
      },
      std::chrono::milliseconds(0));
  EXPECT_EQ(n, 8);
  EXPECT_EQ(seen, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(q.high_water_bytes(), 1024u);
  EXPECT_FALSE(q.Push(1, 0, "X", Payload(0, 2000).data(), 2000));  // larger than the ring
  EXPECT_EQ(q.PopBatch([](const EventView&) {}, std::chrono::milliseconds(0)), 0);
  q.Close();
  EXPECT_EQ(q.PopBatch([](const EventView&) {}, std::chrono::milliseconds(0)), -1);
}

// Oracle: events of varying sizes pushed and popped in interleaved batches
// wrap around the ring many times; every one comes out once, in order,
// unchanged.
TEST(EventQueueTest, WrapsAroundWithoutLosingOrCorrupting) {
  EventQueue q(4096);
  int next_push = 0, next_pop = 0;
  for (int round = 0; round < 200; ++round) {
    for (int k = 0; k < 1 + round % 7; ++k) {
      const std::size_t size = static_cast<std::size_t>((next_push * 37) % 300);
      if (!q.Push(next_push, next_push, "C", Payload(next_push, size).data(), static_cast<uint32_t>(size))) break;
      ++next_push;
    }
    q.PopBatch(
        [&](const EventView& ev) {
          ASSERT_EQ(ev.channel_id, next_pop);
          const std::size_t size = static_cast<std::size_t>((next_pop * 37) % 300);
          ASSERT_EQ(std::string(reinterpret_cast<const char*>(ev.data), ev.size), Payload(next_pop, size));
          ++next_pop;
        },
        std::chrono::milliseconds(0));
  }
  EXPECT_EQ(next_pop, next_push);
  EXPECT_GT(next_push, 500);  // ~60 ring lengths went through
}

// Oracle: the ring's layout (record_test's RecordBytes: 24 bytes of header,
// the first 4 the record's total). A bug elsewhere that writes 0 over the
// second record's total made PopBatch hand that record out again and again
// for ever (its position never moved); now the damaged record and the rest
// of its batch are given up and counted, and the queue goes on.
TEST(EventQueueTest, ADamagedRecordIsCountedNotLoopedOnForEver) {
  EventQueue q(4096);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(q.Push(i, i, "CH", Payload(i, 40).data(), 40));
  const std::size_t first_bytes = EventQueue::RecordBytes(2, 40);
  int calls = 0;
  std::vector<int> seen;
  const int n = q.PopBatch(
      [&](const EventView& ev) {
        if (++calls > 100) throw std::runtime_error("PopBatch loops on the damaged record");
        seen.push_back(ev.channel_id);
        if (ev.channel_id == 0) {
          // The memory bug: zero the next record's total (it starts right
          // after this one's bytes; ev.data is 24 + 2 bytes into this one).
          auto* second = const_cast<uint8_t*>(ev.data) - 24 - 2 + first_bytes;
          std::memset(second, 0, 4);
        }
      },
      std::chrono::milliseconds(0));
  EXPECT_EQ(n, 1);
  EXPECT_EQ(seen, std::vector<int>{0});
  const EventQueue::Damage damage = q.damage();
  EXPECT_EQ(damage.records, 1u);
  EXPECT_EQ(damage.events, 2u);  // the damaged record and the one after it
  EXPECT_EQ(damage.bytes, 2 * first_bytes);
  // The queue is usable again.
  ASSERT_TRUE(q.Push(7, 7, "CH", Payload(7, 40).data(), 40));
  seen.clear();
  EXPECT_EQ(q.PopBatch([&](const EventView& ev) { seen.push_back(ev.channel_id); }, std::chrono::milliseconds(0)), 1);
  EXPECT_EQ(seen, std::vector<int>{7});
  EXPECT_EQ(q.damage().events, 2u);
}

// Oracle: as above; a total that is not 24 + channel + payload rounded to
// 8 (here one too large by 8, which would skip into the next record's
// payload), or a wrap marker with nothing queued after it, is damage too.
TEST(EventQueueTest, ARecordOfTheWrongSizeOrAStrayWrapIsDamage) {
  for (const uint32_t bad : {static_cast<uint32_t>(EventQueue::RecordBytes(2, 40) + 8), 0xFFFFFFFFu}) {
    EventQueue q(4096);
    for (int i = 0; i < 2; ++i) ASSERT_TRUE(q.Push(i, i, "CH", Payload(i, 40).data(), 40));
    std::vector<int> seen;
    const int n = q.PopBatch(
        [&](const EventView& ev) {
          seen.push_back(ev.channel_id);
          if (seen.size() > 10) throw std::runtime_error("PopBatch loops on the damaged record");
          if (ev.channel_id == 0) {
            auto* second = const_cast<uint8_t*>(ev.data) - 24 - 2 + EventQueue::RecordBytes(2, 40);
            std::memcpy(second, &bad, 4);
          }
        },
        std::chrono::milliseconds(0));
    EXPECT_EQ(n, 1) << bad;
    EXPECT_EQ(q.damage().events, 1u) << bad;
  }
}

// The size of event i in the tests below: 0 .. 299 bytes of payload.
std::size_t TestSize(int i) { return static_cast<std::size_t>((i * 37) % 300); }

bool PushTestEvent(EventQueue& q, int i) {
  const std::string payload = Payload(i, TestSize(i));
  return q.Push(i, i, "RL_THETA", payload.data(), static_cast<uint32_t>(payload.size()));
}

// Checks that `ev` is event `expected` (order and content).
void ExpectTestEvent(const EventView& ev, int expected) {
  ASSERT_EQ(ev.channel_id, expected);
  ASSERT_EQ(ev.utime, expected);
  ASSERT_EQ(std::string(ev.channel), "RL_THETA");
  ASSERT_EQ(std::string(reinterpret_cast<const char*>(ev.data), ev.size), Payload(expected, TestSize(expected)));
}

constexpr std::size_t kPage = 4096;

// Oracle: the kernel's count of the ring's resident pages (mincore). A
// writer that keeps up (every event popped before the next comes, the
// recorder at real time) empties the queue before each push, which then
// starts again at the ring's start: five ring lengths of events go through
// one 8 MiB ring and at most its first chunk (64 KiB) is ever resident
// (the events are at most 336 bytes, so in fact its first page). Before,
// the ring advanced through all of its 8 MiB whatever the fill.
TEST(EventQueueTest, AWriterThatKeepsUpTouchesOnlyTheFirstChunk) {
  EventQueue q(8u << 20, 64u << 10);
  ASSERT_EQ(q.release_chunk_bytes(), 64u << 10);
  ASSERT_EQ(q.resident_bytes(), 0u);  // reserved, not resident
  std::size_t through = 0, most_resident = 0;
  int next_pop = 0;
  for (int i = 0; through < 5 * q.capacity_bytes(); ++i) {
    ASSERT_TRUE(PushTestEvent(q, i));
    through += EventQueue::RecordBytes(8, TestSize(i));
    ASSERT_EQ(q.PopBatch([&](const EventView& ev) { ExpectTestEvent(ev, next_pop++); }, std::chrono::milliseconds(0)),
              1);
    if (i % 1000 == 0) most_resident = std::max(most_resident, q.resident_bytes());
  }
  most_resident = std::max(most_resident, q.resident_bytes());
  EXPECT_GT(most_resident, 0u);
  EXPECT_LE(most_resident, q.release_chunk_bytes());
}

// Oracle: mincore again. A writer that stays behind (each event popped
// replaced by a new one pushed during the batch, so the queue is never
// empty and every event goes round the ring, wrapping) keeps resident at
// most the bytes queued plus three chunks: the first (kept for restarts),
// the one the reader is in and the one the writer is in, each whole. Every
// event comes out once, in order, unchanged (a chunk given back while
// still in use would read as zeros).
TEST(EventQueueTest, AWriterThatStaysBehindKeepsOnlyWhatIsQueuedResident) {
  const std::size_t chunk = 64u << 10;
  EventQueue q(8u << 20, chunk);
  int next_push = 0, next_pop = 0;
  for (; next_push < 1000; ++next_push) ASSERT_TRUE(PushTestEvent(q, next_push));
  std::size_t most_resident = 0, through = 0;
  while (through < 5 * q.capacity_bytes()) {
    const int n = q.PopBatch(
        [&](const EventView& ev) {
          ExpectTestEvent(ev, next_pop++);
          through += EventQueue::RecordBytes(ev.channel.size(), ev.size);
          ASSERT_TRUE(PushTestEvent(q, next_push++));
        },
        std::chrono::milliseconds(0));
    ASSERT_EQ(n, 1000);  // the queue held 1000 events at every batch's start
    most_resident = std::max(most_resident, q.resident_bytes());
    if (HasFatalFailure()) return;
  }
  // 2000 events at most in the ring during a batch, 336 bytes each at most.
  const std::size_t queued = 2000 * EventQueue::RecordBytes(8, 299);
  EXPECT_LE(most_resident, queued + 3 * chunk + 2 * kPage);
  EXPECT_GT(most_resident, 0u);
}

// Oracle: mincore. A burst fills the whole ring, which is then resident;
// once the reader has drained it, the next event gives every chunk back
// but the first.
TEST(EventQueueTest, ADrainedBurstIsGivenBack) {
  const std::size_t chunk = 64u << 10;
  EventQueue q(1u << 20, chunk);
  int pushed = 0;
  while (PushTestEvent(q, pushed)) ++pushed;
  EXPECT_GE(q.resident_bytes(), q.capacity_bytes() - kPage);
  EXPECT_GE(q.high_water_bytes(), q.capacity_bytes() - EventQueue::RecordBytes(8, 299));
  int popped = 0;
  EXPECT_EQ(q.PopBatch([&](const EventView& ev) { ExpectTestEvent(ev, popped++); }, std::chrono::milliseconds(0)),
            pushed);
  ASSERT_TRUE(PushTestEvent(q, pushed));
  EXPECT_LE(q.resident_bytes(), chunk);
  EXPECT_EQ(q.PopBatch([&](const EventView& ev) { ExpectTestEvent(ev, popped++); }, std::chrono::milliseconds(0)),
            1);
}

// Oracle: order and content, in a sequence written out by position (one
// pass of the ring is 64 KiB = 256 events of 256 bytes, chunks 4 KiB = 16
// events). The reader has drained to the middle of chunk 12 (52 480); it
// takes a batch up to 78 336, and while it reads, the writer fills the
// ring, coming round into chunk 12's first bytes (positions 114 688 ..
// 118 016 are its bytes 0 .. 3 328 again). Chunk 12 is drained once that
// batch ends, but it must not be given back: its new bytes are unread. A
// queue that gave it back reads zeros there (the check throws to end the
// batch instead of looping on a zero length).
TEST(EventQueueTest, AChunkTheWriterCameRoundIntoIsKept) {
  EventQueue q(64u << 10, 4096);
  const auto push = [&q](int i) {
    const std::string payload = Payload(i, 224);
    return q.Push(i, i, "RL_THETA", payload.data(), 224);
  };
  ASSERT_EQ(EventQueue::RecordBytes(8, 224), 256u);
  int next_push = 0, next_pop = 0;
  const auto check = [&next_pop](const EventView& ev) {
    const int expected = next_pop++;
    if (ev.channel_id != expected || std::string(reinterpret_cast<const char*>(ev.data), ev.size) !=
                                         Payload(expected, 224)) {
      ADD_FAILURE() << "event " << expected << " read as id " << ev.channel_id << ", " << ev.size << " bytes";
      throw std::runtime_error("corrupt event");
    }
  };
  for (; next_push < 205; ++next_push) ASSERT_TRUE(push(next_push));  // [0, 52 480)
  // Batch A: the last event read pushes one more, so the queue is never
  // empty (an empty queue would restart at the ring's start).
  ASSERT_EQ(q.PopBatch(
                [&](const EventView& ev) {
                  check(ev);
                  if (ev.channel_id == 204) {
                    EXPECT_TRUE(push(next_push++));
                  }
                },
                std::chrono::milliseconds(0)),
            205);
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(push(next_push++));  // up to 78 336
  // Batch B: while its first event is read the writer fills the ring.
  int refused = 0;
  ASSERT_EQ(q.PopBatch(
                [&](const EventView& ev) {
                  check(ev);
                  if (ev.channel_id == 205) {
                    while (push(next_push)) ++next_push;
                    ++refused;
                  }
                },
                std::chrono::milliseconds(0)),
            101);
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(next_push, 205 + 1 + 100 + 155);  // 155 more fill [78 336, 118 016)
  ASSERT_TRUE(push(next_push++));             // gives back the chunks batch B drained
  try {
    EXPECT_EQ(q.PopBatch(check, std::chrono::milliseconds(0)), 156);
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(next_pop, next_push);
}

// Oracle: order and content. A producer thread and the consumer (this
// thread) on a small ring with one-page chunks, so that chunks are given
// back all the time while the other side works: every event arrives once,
// in order, unchanged; a refused push (the ring full) is retried, as the
// recorder would count it, so the refusals are counted, not lost.
TEST(EventQueueTest, ThreadsLoseNothingWhileChunksAreGivenBack) {
  EventQueue q(64u << 10, 1);
  ASSERT_EQ(q.release_chunk_bytes(), kPage);
  constexpr int kEvents = 200000;
  std::atomic<int> refused{0};
  std::atomic<bool> abandon{false};  // the consumer failed: the producer stops
  std::thread producer([&] {
    for (int i = 0; i < kEvents && !abandon; ++i) {
      while (!PushTestEvent(q, i) && !abandon) {
        refused.fetch_add(1, std::memory_order_relaxed);
        std::this_thread::yield();
      }
    }
    q.Close();
  });
  int next_pop = 0;
  for (;;) {
    const int n = q.PopBatch([&](const EventView& ev) { ExpectTestEvent(ev, next_pop++); },
                             std::chrono::milliseconds(100));
    if (n < 0) break;
    if (HasFatalFailure()) {
      abandon = true;
      break;
    }
  }
  producer.join();
  EXPECT_EQ(next_pop, kEvents);
  EXPECT_LE(q.high_water_bytes(), q.capacity_bytes());
  std::printf("refused (ring full, retried): %d\n", refused.load());
}

// Oracle: the LCM log format written out by hand (sync word 0xEDA1DA01,
// int64 event number, int64 timestamp, int32 channel length, int32 data
// length, channel, data; big-endian), and LCM's reader on the same file.
TEST(LogWriterTest, WritesTheLcmLogFormat) {
  const std::string path = Scratch("format.lcm");
  {
    LogFileWriter w(path, false);
    ASSERT_TRUE(w.Write(0x0102030405060708LL, 0x1122334455667788LL, "AB", reinterpret_cast<const uint8_t*>("xyz"), 3));
    ASSERT_TRUE(w.Write(1, 0x1122334455667789LL, "RL_RAW", reinterpret_cast<const uint8_t*>(""), 0));
    EXPECT_EQ(w.bytes(), 28 + 2 + 3 + 28 + 6);
    ASSERT_TRUE(w.Close());
  }
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string first("\xED\xA1\xDA\x01"
                          "\x01\x02\x03\x04\x05\x06\x07\x08"
                          "\x11\x22\x33\x44\x55\x66\x77\x88"
                          "\x00\x00\x00\x02"
                          "\x00\x00\x00\x03"
                          "ABxyz",
                          33);
  ASSERT_EQ(bytes.size(), 33u + 34u);
  EXPECT_EQ(bytes.substr(0, 33), first);
  const auto events = ReadLog(path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].channel, "RL_RAW");
  EXPECT_EQ(events[1].utime, 0x1122334455667789LL);
  EXPECT_EQ(events[1].data, "");
}

// Oracle: a recording never replaces another one silently.
TEST(LogWriterTest, RefusesAnExistingFileUnlessOverwriting) {
  const std::string path = Scratch("exists.lcm");
  { std::ofstream(path) << "keep"; }
  try {
    LogFileWriter w(path, false);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos) << e.what();
  }
  { LogFileWriter w(path, true); }
  EXPECT_EQ(FileSize(path), 0);
  EXPECT_THROW(LogFileWriter("no_such_dir/x.lcm", true), std::runtime_error);
}

TEST(LogWriterTest, RotatedNamesArePredictable) {
  EXPECT_EQ(RotatedPath("test.lcm", 0), "test.0000.lcm");
  EXPECT_EQ(RotatedPath("dir.d/test.lcm", 12), "dir.d/test.0012.lcm");
  EXPECT_EQ(RotatedPath("dir.d/test", 3), "dir.d/test.0003");
  EXPECT_EQ(RotatedPath("test", 10000), "test.10000");
  EXPECT_EQ(RotatedPath(".hidden", 1), ".hidden.0001");
}

// Events through a rotating writer; returns what was written, in order.
std::vector<Event> WriteSeries(RotatingLogWriter& w, int n, int64_t dt_us, std::size_t size) {
  std::vector<Event> sent;
  for (int i = 0; i < n; ++i) {
    Event e{i, 1'000'000 + i * dt_us, i % 3 ? "RL_THETA" : "RL_RAW", Payload(i, size + static_cast<std::size_t>(i % 5))};
    EXPECT_TRUE(w.Write(e.utime, e.channel, reinterpret_cast<const uint8_t*>(e.data.data()),
                        static_cast<uint32_t>(e.data.size())));
    sent.push_back(e);
  }
  EXPECT_TRUE(w.Close());
  return sent;
}

// Oracle: the concatenation of the rotated files is the series sent, event
// for event (no event lost or repeated, numbers continuing), and no file
// passes the size limit.
TEST(LogWriterTest, RotatesBySizeWithoutLosingOrRepeating) {
  RotationOptions o;
  o.path = Scratch("size.lcm");
  o.rotate_bytes = 4000;
  o.overwrite = true;
  RotatingLogWriter w(o);
  const auto sent = WriteSeries(w, 500, 1000, 100);
  std::vector<Event> got;
  ASSERT_GT(w.files().size(), 10u);
  for (std::size_t i = 0; i < w.files().size(); ++i) {
    EXPECT_EQ(w.files()[i], RotatedPath(o.path, static_cast<int>(i)));
    EXPECT_LE(FileSize(w.files()[i]), 4000) << w.files()[i];
    if (i + 1 < w.files().size()) {  // each but the last filled up to the last event that fits
      EXPECT_GT(FileSize(w.files()[i]), 4000 - (28 + 8 + 104)) << w.files()[i];
    }
    for (auto& e : ReadLog(w.files()[i])) got.push_back(e);
  }
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].number, static_cast<int64_t>(i));
    EXPECT_EQ(got[i].utime, sent[i].utime);
    EXPECT_EQ(got[i].channel, sent[i].channel);
    EXPECT_EQ(got[i].data, sent[i].data);
  }
  EXPECT_EQ(w.events(), 500);
}

// A provenance sidecar's rows (key,value, both quoted), by key; empty when
// the file is missing.
std::map<std::string, std::string> SidecarRows(const std::string& path) {
  std::map<std::string, std::string> rows;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return rows;
  EXPECT_EQ(line, "key,value") << path;
  const std::regex row(R"re("([a-z0-9_]+)","(.*)")re");
  while (std::getline(in, line)) {
    std::smatch m;
    EXPECT_TRUE(std::regex_match(line, m, row)) << path << ": " << line;
    if (m.size() == 3) rows[m[1]] = m[2];
  }
  return rows;
}

// Every file of a rotated series gets its own sidecar once it is finished,
// saying which events it holds; none while a file is being written (a
// stale one of an earlier recording is removed at its start).
// Oracle: the source holds "abc", whose SHA-256 is FIPS 180-2's example
// (ba7816bf...15ad); each file's events, first event number and size are
// read back with LCM's reader and stat().
TEST(LogWriterTest, EachFinishedFileCarriesItsOwnProvenance) {
  const std::string source = Scratch("source.txt");
  std::ofstream(source, std::ios::binary) << "abc";
  RotationOptions o;
  o.path = Scratch("prov.lcm");
  o.rotate_bytes = 4000;
  o.overwrite = true;
  const std::string first_sidecar = RotatedPath(o.path, 0) + ".provenance.csv";
  std::ofstream(first_sidecar) << "key,value\n\"stale\",\"from an earlier recording\"\n";
  LogProvenance provenance({source}, {{"rig", "test rig"}});
  provenance.Attach(o);
  RotatingLogWriter w(o);
  EXPECT_FALSE(std::ifstream(first_sidecar).good()) << "a stale sidecar beside the file being written";
  const auto sent = WriteSeries(w, 120, 1000, 100);
  ASSERT_GE(w.files().size(), 3u);
  provenance.Drain();  // the sidecars are written on the provenance's own thread
  int64_t next_event = 0;
  for (std::size_t i = 0; i < w.files().size(); ++i) {
    const std::string& f = w.files()[i];
    auto rows = SidecarRows(f + ".provenance.csv");
    const auto events = ReadLog(f);
    ASSERT_FALSE(events.empty()) << f;
    EXPECT_EQ(rows["source_1"],
              source + " (3 bytes, sha256 ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad)");
    EXPECT_EQ(rows["rig"], "test rig");
    EXPECT_EQ(rows["log_series"], o.path);
    EXPECT_EQ(rows["log_file_index"], std::to_string(i));
    EXPECT_EQ(rows["first_event"], std::to_string(events.front().number));
    EXPECT_EQ(rows["first_event"], std::to_string(next_event));
    EXPECT_EQ(rows["events"], std::to_string(events.size()));
    EXPECT_EQ(rows["bytes"], std::to_string(FileSize(f)));
    EXPECT_EQ(rows["first_utime_us"], std::to_string(events.front().utime));
    EXPECT_EQ(rows["last_utime_us"], std::to_string(events.back().utime));
    EXPECT_EQ(rows.count("rocklab_version") + rows.count("command") + rows.count("created_utc"), 3u);
    EXPECT_EQ(rows.count("stale"), 0u);
    next_event += static_cast<int64_t>(events.size());
  }
  EXPECT_EQ(next_event, static_cast<int64_t>(sent.size()));
  EXPECT_EQ(provenance.errors(), 0);
}

// The sidecars are written on the provenance's thread, not the writer's;
// whatever is still queued when the provenance goes (the end of a daq or
// record run without a call to errors()) is written before it is gone.
// Oracle: every file of the series has its sidecar, naming its index.
TEST(LogWriterTest, SidecarsStillQueuedAreWrittenWhenTheProvenanceGoes) {
  RotationOptions o;
  o.path = Scratch("prov_queued.lcm");
  o.rotate_bytes = 2000;
  o.overwrite = true;
  std::vector<std::string> files;
  {
    LogProvenance provenance({}, {});
    provenance.Attach(o);
    RotatingLogWriter w(o);
    WriteSeries(w, 200, 1000, 100);
    files = w.files();
  }
  ASSERT_GE(files.size(), 8u);
  for (std::size_t i = 0; i < files.size(); ++i) {
    auto rows = SidecarRows(files[i] + ".provenance.csv");
    EXPECT_EQ(rows["log_file_index"], std::to_string(i)) << files[i];
  }
}

// Oracle: with 10 ms between events and 0.25 s per file, each file holds the
// events of [k * 0.25, (k + 1) * 0.25) s after its first: 25 events.
TEST(LogWriterTest, RotatesByTime) {
  RotationOptions o;
  o.path = Scratch("time.lcm");
  o.rotate_seconds = 0.25;
  o.overwrite = true;
  RotatingLogWriter w(o);
  WriteSeries(w, 100, 10'000, 10);
  ASSERT_EQ(w.files().size(), 4u);
  for (const auto& f : w.files()) {
    const auto events = ReadLog(f);
    ASSERT_EQ(events.size(), 25u) << f;
    EXPECT_LT(events.back().utime - events.front().utime, 250'000) << f;
  }
}

// Oracle: timestamps never decrease in the log, whatever the host clock did.
TEST(LogWriterTest, TimestampsNeverDecrease) {
  RotationOptions o;
  o.path = Scratch("clock.lcm");
  o.overwrite = true;
  RotatingLogWriter w(o);
  for (int64_t t : {100, 200, 150, 300}) ASSERT_TRUE(w.Write(t, "C", reinterpret_cast<const uint8_t*>("x"), 1));
  ASSERT_TRUE(w.Close());
  const auto events = ReadLog(o.path);
  ASSERT_EQ(events.size(), 4u);
  EXPECT_EQ(events[2].utime, 200);
  EXPECT_EQ(events[3].utime, 300);
}

TEST(LogWriterTest, RejectsBadOptions) {
  RotationOptions o;
  o.path = "x.lcm";  // lint: name-ok: never opened, Validate() only
  o.rotate_bytes = -1;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.rotate_bytes = 0;
  o.rotate_seconds = -2;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

std::string RawFrame(int64_t seq) {
  rocklab::raw_frame_t m{};
  m.utime = seq * 1000;
  m.seq = seq;
  m.num_channels = 2;
  m.values = {0.5, static_cast<double>(seq)};
  std::string buf(static_cast<std::size_t>(m.getEncodedSize()), '\0');
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

void HandleAll(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

// Oracle: counts of what the test published, channel by channel; sequence
// numbers of raw_frame_t (0 1 2 5 6 6 4 7: 2 -> 5 skips two, 6 repeats, 4
// goes back, 4 -> 7 skips two); a channel outside the regex is not recorded; the log holds the
// published events in order.
TEST(RecorderTest, CountsChannelsAndSequenceGapsOverMemq) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  RecorderOptions o;
  o.out_path = Scratch("memq.lcm");
  o.channels = "RL_.*";
  Recorder rec(lcm, o);
  std::vector<Event> sent;
  for (int64_t seq : {0, 1, 2, 5, 6, 6, 4, 7}) {
    const std::string raw = RawFrame(seq);
    lcm.publish("RL_RAW", raw.data(), static_cast<unsigned>(raw.size()));
    sent.push_back({0, 0, "RL_RAW", raw});
    lcm.publish("RL_EVENT", "e", 1);
    sent.push_back({0, 0, "RL_EVENT", "e"});
    lcm.publish("OTHER", "o", 1);
    HandleAll(lcm);
  }
  rec.Stop();
  const RecorderStats s = rec.Stats();
  ASSERT_EQ(s.channels.size(), 2u);
  EXPECT_EQ(s.channels[0].name, "RL_RAW");
  EXPECT_EQ(s.channels[0].count, 8);
  EXPECT_EQ(s.channels[0].received, 8);
  EXPECT_EQ(s.channels[0].dropped, 0);
  EXPECT_TRUE(s.channels[0].seq.any);
  // 2 -> 5 skips 3 and 4; 4 then arrives late and fills its place, so only
  // 3 is missing (issue 34: the old rule took 4 as a step back and counted
  // 5 and 6 missing again at 4 -> 7).
  EXPECT_EQ(s.channels[0].seq.gaps, 1);
  EXPECT_EQ(s.channels[0].seq.missing, 1);
  EXPECT_EQ(s.channels[0].seq.back, 2);     // 6 again, then 4
  EXPECT_EQ(s.channels[0].seq.duplicates, 1);
  EXPECT_EQ(s.channels[0].seq.late, 1);
  EXPECT_EQ(s.channels[1].name, "RL_EVENT");
  EXPECT_EQ(s.channels[1].count, 8);
  EXPECT_FALSE(s.channels[1].seq.any);
  EXPECT_EQ(s.events, 16);
  EXPECT_EQ(s.dropped, 0);
  ASSERT_EQ(s.files, std::vector<std::string>{o.out_path});
  const auto got = ReadLog(o.out_path);
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].channel, sent[i].channel);
    EXPECT_EQ(got[i].data, sent[i].data);
    if (i > 0) {
      EXPECT_GE(got[i].utime, got[i - 1].utime);
    }
  }
  const std::string json = SummaryJson(s);
  for (const char* key : {"\"channels\"", "\"name\"", "\"count\"", "\"dropped\"", "\"seq_gaps\"", "\"files\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key;
  }
}

// Oracle: nothing read is lost without a counter. A queue far smaller than
// the burst (64 KiB against 20 000 x 1 KiB) while the writer runs: for every
// channel, written + dropped = received = published, and the log holds
// exactly the written events, in order (their sequence numbers increase).
TEST(RecorderTest, EveryEventIsWrittenOrCounted) {
  lcm::LCM lcm("memq://");
  RecorderOptions o;
  o.out_path = Scratch("burst.lcm");
  o.queue_bytes = 1 << 16;
  o.rotate_bytes = 1 << 20;
  Recorder rec(lcm, o);
  rocklab::table_state_t m{};
  std::string buf;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    m.seq = i;
    m.utime = i;
    buf.assign(static_cast<std::size_t>(m.getEncodedSize()), '\0');
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    buf.resize(1024, 'p');  // padding after the encoding: the seq is still read
    lcm.publish("RL_TABLE", buf.data(), static_cast<unsigned>(buf.size()));
    HandleAll(lcm);
  }
  rec.Stop();
  const RecorderStats s = rec.Stats();
  ASSERT_EQ(s.channels.size(), 1u);
  const ChannelStats& c = s.channels[0];
  std::printf("burst: %lld written, %lld dropped, %lld gaps, queue high water %zu of %zu bytes\n",
              static_cast<long long>(c.count), static_cast<long long>(c.dropped),
              static_cast<long long>(c.seq.gaps), s.queue_high_water_bytes, s.queue_bytes);
  EXPECT_EQ(c.received, n);
  EXPECT_EQ(c.count + c.dropped, n);
  // The recorder's own drops show in the sequence numbers: before the first
  // written, in the gaps, after the last.
  if (c.count > 0) {
    ASSERT_EQ(c.seq.senders.size(), 1u);  // one sender: table_state_t has no sender field
    const common::SeqGaps& g = c.seq.senders[0].second;
    EXPECT_EQ(g.first() + c.seq.missing + (n - 1 - g.highest()), c.dropped);
  }
  int64_t in_log = 0, last = -1;
  for (const auto& f : s.files) {
    for (const auto& e : ReadLog(f)) {
      rocklab::table_state_t d{};
      ASSERT_GE(d.decode(e.data.data(), 0, static_cast<int>(e.data.size())), 0);
      EXPECT_GT(d.seq, last);
      last = d.seq;
      ++in_log;
    }
  }
  EXPECT_EQ(in_log, c.count);
}

TEST(RecorderTest, RejectsBadOptions) {
  lcm::LCM lcm("memq://");
  RecorderOptions o;
  o.out_path = Scratch("bad.lcm");
  o.queue_bytes = 100;
  EXPECT_THROW(Recorder(lcm, o), std::invalid_argument);
  o.queue_bytes = 1 << 20;
  o.out_path = "no_such_dir/x.lcm";
  EXPECT_THROW(Recorder(lcm, o), std::runtime_error);
}

}  // namespace
}  // namespace rocklab::record
