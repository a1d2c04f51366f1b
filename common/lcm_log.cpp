#include "common/lcm_log.h"
#include "common/cancel.h"
#include "common/channel_pattern.h"
#include "common/seq_gaps.h"

#include <algorithm>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <regex>
#include <stdexcept>
#include <unordered_map>

namespace rocklab::common {
namespace {

constexpr std::size_t kHeaderBytes = 28;  // sync, number, stamp, two lengths
constexpr std::size_t kReadChunk = 1 << 20;

std::uint32_t U32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}
std::int64_t I64(const std::uint8_t* p) {
  return static_cast<std::int64_t>((std::uint64_t{U32(p)} << 32) | U32(p + 4));
}
void Put32(char* p, std::uint32_t v) {
  for (int i = 3; i >= 0; --i, v >>= 8) p[i] = static_cast<char>(v & 0xff);
}
void Put64(char* p, std::uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<char>(v & 0xff);
}

}  // namespace

std::string ToString(const LogProblem& p) {
  return p.file + ": damaged region at byte offset " + std::to_string(p.offset) + " (" +
         std::to_string(p.bytes) + " bytes, " + std::to_string(p.events) + " event" +
         (p.events == 1 ? "" : "s") + " skipped): " + p.what;
}

void LogReaderOptions::Validate() const {
  ChannelPattern(channels, "channels");
  if (!(start_s >= 0) || !std::isfinite(start_s)) throw std::invalid_argument("start must be >= 0 s");
  if (std::isnan(end_s) || (end_s >= 0 && end_s <= start_s)) {
    throw std::invalid_argument("end must be after start");
  }
  if (!(end_slack_s >= 0)) throw std::invalid_argument("end_slack_s must be >= 0 s");
  if (max_channel_bytes < 1) throw std::invalid_argument("max_channel_bytes must be >= 1");
  if (max_data_bytes < 0) throw std::invalid_argument("max_data_bytes must be >= 0");
}

struct LogReader::Impl {
  std::string path;
  LogReaderOptions o;
  std::regex filter;
  std::unordered_map<std::string, bool> matches;  // channel -> passes (regex once per channel)
  std::FILE* file{};
  std::int64_t file_size{};

  // Read buffer: bytes [pos, end) of buf are the file from offset buf_offset + pos.
  std::vector<std::uint8_t> buf;
  std::size_t pos{}, end{};
  std::int64_t buf_offset{};
  bool eof{};

  LogReadCounts counts;
  std::int64_t t0{};
  std::int64_t window_start{INT64_MIN}, window_end{INT64_MAX}, stop_after{INT64_MAX};
  std::int64_t first_in_window_offset{-1};
  std::int64_t reported_up_to{};  // damage below this offset was reported on an earlier pass
  bool have_last_good{};
  std::int64_t last_good_number{};
  bool damage_open{};
  std::int64_t damage_offset{};
  std::string damage_what;
  LogEvent ahead;
  bool have_ahead{}, ended{};

  ~Impl() {
    if (file) std::fclose(file);
  }

  std::int64_t Offset() const { return buf_offset + static_cast<std::int64_t>(pos); }

  // Makes n bytes available at pos (n bounded by the caller); false when the
  // file ends first.
  bool Ensure(std::size_t n) {
    if (end - pos >= n) return true;
    if (eof) return false;
    if (pos > 0) {
      std::memmove(buf.data(), buf.data() + pos, end - pos);
      buf_offset += static_cast<std::int64_t>(pos);
      end -= pos;
      pos = 0;
    }
    if (buf.size() < std::max(n, kReadChunk)) buf.resize(std::max(n, kReadChunk));
    while (end < n) {
      const std::size_t got = std::fread(buf.data() + end, 1, buf.size() - end, file);
      end += got;
      if (got == 0) {
        eof = true;
        break;
      }
    }
    return end - pos >= n;
  }

  void Seek(std::int64_t offset) {
    std::fseek(file, static_cast<long>(offset), SEEK_SET);
    pos = end = 0;
    buf_offset = offset;
    eof = false;
    have_last_good = false;
    damage_open = false;
  }

  // Empty when the lengths of a header at `at` can be those of an event.
  std::string CheckLengths(std::int64_t at, std::int32_t channel_len, std::int32_t data_len) const {
    if (channel_len < 1 || channel_len > o.max_channel_bytes) {
      return "impossible channel length " + std::to_string(channel_len);
    }
    if (data_len < 0 || data_len > o.max_data_bytes) {
      return "impossible data length " + std::to_string(data_len);
    }
    const std::int64_t need = static_cast<std::int64_t>(kHeaderBytes) + channel_len + data_len;
    if (at + need > file_size) {
      return "an event of " + std::to_string(need) + " bytes where " +
             std::to_string(file_size - at) + " are left (a cut tail)";
    }
    return {};
  }

  bool PrintableChannel(const std::uint8_t* p, std::int32_t n) const {
    for (std::int32_t i = 0; i < n; ++i) {
      if (p[i] < 0x20 || p[i] > 0x7e) return false;
    }
    return true;
  }

  // True when a plausible event header starts at pos.
  bool PlausibleHeader() {
    if (!Ensure(kHeaderBytes)) return false;
    const std::uint8_t* p = buf.data() + pos;
    if (U32(p) != kLcmLogSync) return false;
    const std::int32_t channel_len = static_cast<std::int32_t>(U32(p + 20));
    const std::int32_t data_len = static_cast<std::int32_t>(U32(p + 24));
    if (!CheckLengths(Offset(), channel_len, data_len).empty()) return false;
    if (!Ensure(kHeaderBytes + channel_len)) return false;
    return PrintableChannel(buf.data() + pos + kHeaderBytes, channel_len);
  }

  // Moves past the damaged byte at pos to the next plausible header (or the end).
  void Scan() {
    ++pos;
    while (Ensure(4)) {
      const void* hit = std::memchr(buf.data() + pos, 0xED, end - pos);
      if (hit == nullptr) {
        pos = end;
        continue;
      }
      pos = static_cast<std::size_t>(static_cast<const std::uint8_t*>(hit) - buf.data());
      if (PlausibleHeader()) return;
      ++pos;
    }
    pos = end;
  }

  void OpenDamage(std::int64_t at, std::string what) {
    if (damage_open) return;
    damage_open = true;
    damage_offset = at;
    damage_what = std::move(what);
  }

  // Ends an open damaged region at offset `end_offset`; `next_number` is the
  // event number of the event after it (< 0: none, the file ended).
  void CloseDamage(std::int64_t end_offset, std::int64_t next_number) {
    if (!damage_open) return;
    damage_open = false;
    LogProblem p;
    p.file = path;
    p.offset = damage_offset;
    p.bytes = end_offset - damage_offset;
    p.what = damage_what;
    const std::int64_t most = p.bytes / static_cast<std::int64_t>(kHeaderBytes) + 1;
    std::int64_t lost = 1;
    if (next_number >= 0) {
      // Numbers come from the file: the difference is taken without overflow.
      const std::int64_t gap = !have_last_good                  ? next_number
                               : next_number > last_good_number ? SeqGaps::Skipped(last_good_number, next_number)
                                                                : 0;
      if (gap >= 1 && gap <= most) lost = gap;
    }
    p.events = lost;
    if (damage_offset < reported_up_to) return;  // an earlier pass reported it
    ++counts.damaged_regions;
    counts.damaged_bytes += p.bytes;
    counts.damaged_events += p.events;
    if (o.on_problem) o.on_problem(p);
  }

  // The next well-formed event in file order, damage skipped; false at the end.
  bool ReadRaw(LogEvent& ev) {
    for (;;) {
      const std::int64_t at = Offset();
      if (!Ensure(kHeaderBytes)) {
        if (end > pos) {
          OpenDamage(at, "the log ends inside an event header (a cut tail)");
          pos = end;
        }
        CloseDamage(Offset(), -1);
        reported_up_to = std::max(reported_up_to, Offset());
        return false;
      }
      const std::uint8_t* p = buf.data() + pos;
      const std::uint32_t sync = U32(p);
      if (sync != kLcmLogSync) {
        char what[64];
        std::snprintf(what, sizeof what, "bad sync word 0x%08X", sync);
        OpenDamage(at, what);
        Scan();
        continue;
      }
      const std::int64_t number = I64(p + 4);
      const std::int64_t stamp = I64(p + 12);
      const std::int32_t channel_len = static_cast<std::int32_t>(U32(p + 20));
      const std::int32_t data_len = static_cast<std::int32_t>(U32(p + 24));
      std::string bad = CheckLengths(at, channel_len, data_len);
      const std::size_t total = kHeaderBytes + static_cast<std::size_t>(channel_len > 0 ? channel_len : 0) +
                                static_cast<std::size_t>(data_len > 0 ? data_len : 0);
      if (bad.empty() && !Ensure(total)) bad = "the file ended early (it shrank while read)";
      if (bad.empty() && !PrintableChannel(buf.data() + pos + kHeaderBytes, channel_len)) {
        bad = "channel name is not printable text";
      }
      if (!bad.empty()) {
        OpenDamage(at, bad);
        Scan();
        continue;
      }
      const std::uint8_t* q = buf.data() + pos + kHeaderBytes;
      ev.number = number;
      ev.timestamp_us = stamp;
      ev.offset = at;
      ev.channel.assign(reinterpret_cast<const char*>(q), static_cast<std::size_t>(channel_len));
      ev.data.assign(q + channel_len, q + channel_len + data_len);
      pos += total;
      CloseDamage(at, number);
      have_last_good = true;
      last_good_number = number;
      reported_up_to = std::max(reported_up_to, Offset());
      ++counts.events;
      return true;
    }
  }

  bool Advance(LogEvent& ev) {
    if (ended) return false;
    while (ReadRaw(ev)) {
      PollThreadCancel();  // every event, filtered out or not: a reader may skip a whole log
      if (ev.timestamp_us > stop_after) break;
      if (ev.timestamp_us < window_start || ev.timestamp_us > window_end) {
        ++counts.outside_window;
        continue;
      }
      if (first_in_window_offset < 0) first_in_window_offset = ev.offset;
      auto it = matches.find(ev.channel);
      if (it == matches.end()) it = matches.emplace(ev.channel, std::regex_match(ev.channel, filter)).first;
      if (!it->second) {
        ++counts.filtered;
        continue;
      }
      ++counts.delivered;
      return true;
    }
    ended = true;
    return false;
  }
};

LogReader::LogReader(const std::string& path, LogReaderOptions options)
    : impl_(std::make_unique<Impl>()) {
  options.Validate();
  Impl& m = *impl_;
  m.path = path;
  m.o = std::move(options);
  m.filter = ChannelPattern(m.o.channels, "channels");
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw std::runtime_error("cannot read LCM log '" + path + "': it is a folder");
  }
  m.file = std::fopen(path.c_str(), "rb");
  if (m.file == nullptr) {
    throw std::runtime_error("cannot read LCM log '" + path + "': " + std::strerror(errno));
  }
  const auto size = std::filesystem::file_size(path, ec);
  m.file_size = ec ? 0 : static_cast<std::int64_t>(size);
  LogEvent first;
  if (!m.ReadRaw(first)) {
    throw std::runtime_error("'" + path + "' is not an LCM log (no LCM event in its " +
                             std::to_string(m.file_size) + " bytes)");
  }
  m.t0 = first.timestamp_us;
  // Stamps come from the file: a window past INT64_MAX ends there.
  const auto plus = [](std::int64_t t_us, double d_s) {
    std::int64_t sum = 0;
    return __builtin_add_overflow(t_us, std::llround(d_s * 1e6), &sum) ? std::numeric_limits<std::int64_t>::max() : sum;
  };
  if (m.o.start_s > 0) m.window_start = plus(m.t0, m.o.start_s);
  if (m.o.end_s >= 0) {
    m.window_end = plus(m.t0, m.o.end_s);
    m.stop_after = plus(m.window_end, m.o.end_slack_s);
  }
  m.counts.events = 0;  // read again by Next
  m.Seek(0);
}

LogReader::~LogReader() = default;

bool LogReader::Next(LogEvent& event) {
  Impl& m = *impl_;
  if (m.have_ahead) {
    std::swap(event, m.ahead);
    m.have_ahead = false;
    return true;
  }
  return m.Advance(event);
}

std::int64_t LogReader::NextEventTimeUs() {
  Impl& m = *impl_;
  if (!m.have_ahead) m.have_ahead = m.Advance(m.ahead);
  return m.have_ahead ? m.ahead.timestamp_us : INT64_MAX;
}

void LogReader::Rewind() {
  Impl& m = *impl_;
  m.Seek(m.first_in_window_offset >= 0 ? m.first_in_window_offset : 0);
  m.have_ahead = false;
  m.ended = false;
}

const LogReadCounts& LogReader::counts() const { return impl_->counts; }
std::int64_t LogReader::first_timestamp_us() const { return impl_->t0; }
const std::string& LogReader::path() const { return impl_->path; }

bool StartsWithLcmSync(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  std::uint8_t b[4] = {};
  const bool got = std::fread(b, 1, 4, f) == 4;
  std::fclose(f);
  return got && U32(b) == kLcmLogSync;
}

namespace {
constexpr std::size_t kWriterBufferBytes = 1 << 20;
}  // namespace

LogWriter::LogWriter(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0) {
    throw std::runtime_error("cannot write LCM log '" + path + "': " + std::strerror(errno));
  }
  buffer_.reserve(kWriterBufferBytes + 4096);
}

LogWriter::~LogWriter() { Close(); }

bool LogWriter::Write(const std::string& channel, const void* data, std::size_t size,
                      std::int64_t timestamp_us) {
  if (fd_ < 0 || channel.empty() || size > static_cast<std::size_t>(INT32_MAX)) {
    ++write_errors_;
    return false;
  }
  if (timestamp_us < last_stamp_) {
    timestamp_us = last_stamp_;
    ++raised_stamps_;
  }
  char header[kHeaderBytes];
  Put32(header, kLcmLogSync);
  Put64(header + 4, static_cast<std::uint64_t>(next_number_++));
  Put64(header + 12, static_cast<std::uint64_t>(timestamp_us));
  Put32(header + 20, static_cast<std::uint32_t>(channel.size()));
  Put32(header + 24, static_cast<std::uint32_t>(size));
  // The buffer's capacity is reserved: no allocation unless one event is
  // larger than it.
  buffer_.insert(buffer_.end(), header, header + kHeaderBytes);
  buffer_.insert(buffer_.end(), channel.begin(), channel.end());
  if (size > 0) {
    const char* bytes = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), bytes, bytes + size);
  }
  ++buffered_events_;
  ++events_;
  last_stamp_ = timestamp_us;
  if (buffer_.size() >= kWriterBufferBytes) return Flush();
  return true;
}

bool LogWriter::Flush() {
  std::size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (error_.empty()) error_ = n < 0 ? std::strerror(errno) : "nothing written";
      // Every buffered event is lost (one cut short leaves a damaged tail).
      events_ -= buffered_events_;
      write_errors_ += buffered_events_;
      buffered_events_ = 0;
      buffer_.clear();
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  buffered_events_ = 0;
  buffer_.clear();
  return true;
}

bool LogWriter::Close() {
  if (fd_ < 0) return true;
  bool ok = Flush();
  if (::close(fd_) != 0) {
    // The kernel took the bytes but reports a failure: which events reached
    // the disk is not known; counted once.
    if (error_.empty()) error_ = std::strerror(errno);
    ++write_errors_;
    ok = false;
  }
  fd_ = -1;
  return ok;
}

}  // namespace rocklab::common
