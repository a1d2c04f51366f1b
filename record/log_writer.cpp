#include "record/log_writer.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace rocklab::record {
namespace {

constexpr uint32_t kSyncWord = 0xEDA1DA01u;

void PutBe32(uint8_t* p, uint32_t v) {
  for (int i = 3; i >= 0; --i) {
    p[i] = static_cast<uint8_t>(v & 0xFF);
    v >>= 8;
  }
}
void PutBe64(uint8_t* p, uint64_t v) {
  for (int i = 7; i >= 0; --i) {
    p[i] = static_cast<uint8_t>(v & 0xFF);
    v >>= 8;
  }
}

}  // namespace

LogFileWriter::LogFileWriter(const std::string& path, bool overwrite) : path_(path) {
  // O_EXCL: a recording never silently replaces another one.
  const int flags = O_WRONLY | O_CREAT | (overwrite ? O_TRUNC : O_EXCL);
  const int fd = ::open(path.c_str(), flags, 0644);
  if (fd < 0) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot create the log: " + std::strerror(err) +
                             (err == EEXIST ? " (give --force to replace it)" : ""));
  }
  file_ = ::fdopen(fd, "wb");
  if (!file_) {
    ::close(fd);
    throw std::runtime_error(path + ": cannot open the log: " + std::strerror(errno));
  }
  buffer_.resize(1 << 20);
  std::setvbuf(file_, buffer_.data(), _IOFBF, buffer_.size());
}

LogFileWriter::~LogFileWriter() { (void)Close(); }

void LogFileWriter::Fail(const char* what) {
  if (error_.empty()) error_ = path_ + ": " + what + ": " + std::strerror(errno);
}

bool LogFileWriter::Write(int64_t event_number, int64_t utime, std::string_view channel, const uint8_t* data,
                          uint32_t size) {
  if (!file_) return false;
  uint8_t header[28];
  PutBe32(header, kSyncWord);
  PutBe64(header + 4, static_cast<uint64_t>(event_number));
  PutBe64(header + 12, static_cast<uint64_t>(utime));
  PutBe32(header + 20, static_cast<uint32_t>(channel.size()));
  PutBe32(header + 24, size);
  if (std::fwrite(header, 1, sizeof header, file_) != sizeof header ||
      std::fwrite(channel.data(), 1, channel.size(), file_) != channel.size() ||
      (size > 0 && std::fwrite(data, 1, size, file_) != size)) {
    Fail("write failed");
    return false;
  }
  bytes_ += EventBytes(channel.size(), size);
  ++events_;
  return true;
}

bool LogFileWriter::Flush() {
  if (!file_) return false;
  if (std::fflush(file_) != 0) {
    Fail("flush failed");
    return false;
  }
  return true;
}

bool LogFileWriter::Close() {
  if (!file_) return error_.empty();
  bool ok = std::fflush(file_) == 0;
  if (!ok) Fail("flush failed");
  if (std::fclose(file_) != 0 && ok) {
    ok = false;
    Fail("close failed");
  }
  file_ = nullptr;
  return ok && error_.empty();
}

void RotationOptions::Validate() const {
  if (path.empty()) throw std::invalid_argument("the output log path is empty");
  if (rotate_bytes < 0) {
    throw std::invalid_argument("--rotate-size must be >= 0 bytes (0: never), got " + std::to_string(rotate_bytes));
  }
  if (!std::isfinite(rotate_seconds) || rotate_seconds < 0) {
    throw std::invalid_argument("--rotate-seconds must be >= 0 s (0: never), got " + std::to_string(rotate_seconds));
  }
}

std::string RotatedPath(const std::string& path, int index) {
  char number[16];
  std::snprintf(number, sizeof number, ".%04d", index);
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) || dot == slash + 1 ||
      (slash == std::string::npos && dot == 0)) {
    return path + number;
  }
  return path.substr(0, dot) + number + path.substr(dot);
}

RotatingLogWriter::RotatingLogWriter(RotationOptions options) : options_(std::move(options)) {
  options_.Validate();
  const std::string first = options_.rotates() ? RotatedPath(options_.path, 0) : options_.path;
  file_ = std::make_unique<LogFileWriter>(first, options_.overwrite);
  files_.push_back(first);
  if (options_.on_started) options_.on_started(first);
}

bool RotatingLogWriter::CloseFile() {
  const std::unique_ptr<LogFileWriter> done = std::move(file_);
  bytes_done_ += done->bytes();
  const bool ok = done->Close();
  if (!ok && error_.empty()) error_ = done->error();
  if (ok && options_.on_finished) {
    FinishedLogFile f;
    f.path = done->path();
    f.index = static_cast<int>(files_.size()) - 1;
    f.first_event = next_event_ - done->events();
    f.events = done->events();
    f.bytes = done->bytes();
    f.first_utime = done->events() > 0 ? file_first_utime_ : 0;
    f.last_utime = done->events() > 0 ? last_utime_ : 0;
    options_.on_finished(f);
  }
  return ok;
}

bool RotatingLogWriter::Open(int index) {
  if (file_ && !CloseFile()) return false;
  const std::string next = RotatedPath(options_.path, index);
  try {
    file_ = std::make_unique<LogFileWriter>(next, options_.overwrite);
  } catch (const std::runtime_error& e) {
    error_ = e.what();
    return false;
  }
  files_.push_back(next);
  if (options_.on_started) options_.on_started(next);
  return true;
}

bool RotatingLogWriter::Write(int64_t utime, std::string_view channel, const uint8_t* data, uint32_t size) {
  utime = std::max(utime, last_utime_);
  if (file_ && file_->events() > 0) {
    const bool by_size = options_.rotate_bytes > 0 &&
                         file_->bytes() + LogFileWriter::EventBytes(channel.size(), size) > options_.rotate_bytes;
    const bool by_time = options_.rotate_seconds > 0 &&
                         static_cast<double>(utime) - static_cast<double>(file_first_utime_) >= options_.rotate_seconds * 1e6;
    if ((by_size || by_time) && !Open(static_cast<int>(files_.size()))) return false;
  }
  if (!file_) {
    // A failed rotation: try again to open the next file.
    if (!Open(static_cast<int>(files_.size()))) return false;
  }
  if (file_->events() == 0) file_first_utime_ = utime;
  if (!file_->Write(next_event_, utime, channel, data, size)) {
    if (error_.empty()) error_ = file_->error();
    return false;
  }
  ++next_event_;
  last_utime_ = utime;
  return true;
}

bool RotatingLogWriter::Flush() { return file_ && file_->Flush(); }

bool RotatingLogWriter::Close() {
  if (!file_) return error_.empty();
  return CloseFile();
}

}  // namespace rocklab::record
