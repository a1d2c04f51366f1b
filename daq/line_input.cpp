#include "daq/line_input.h"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>


namespace rocklab::daq::detail {
namespace {

using Clock = std::chrono::steady_clock;

// What a Fill found.
enum class Fill {
  kData,     // bytes in the buffer
  kNothing,  // nothing yet (live inputs: it waited a little)
  kBreak,    // the byte stream broke: a line in progress ends here
  kRestart,  // a new stream begins (its header comes first)
  kEnd,      // plain inputs: the end of the file or stream
};

// Line splitting over a block buffer, and for the live inputs the stop
// flag, the idle timeout and the wait slices; the byte source is the
// subclass's FillBuffer. A line within the buffer is returned as a view of
// it; a line cut by the buffer's end is carried over in pending_ (at most
// max_bytes of it), so memory is the buffer plus max_bytes whatever the
// input.
class BlockLineInput : public LineInput {
 public:
  BlockLineInput(bool live, const LiveOptions& options)
      : live_(live), options_(options), buffer_(kBlockBytes) {
    last_byte_ = Clock::now();
  }
  bool live() const override { return live_; }

  LineStatus Read(std::string_view& line, bool& too_long, std::size_t max_bytes, bool may_idle) override {
    line = {};
    too_long = false;
    if (pending_taken_) {
      // The caller is done with the line it was given from pending_.
      pending_taken_ = false;
      pending_.clear();
    }
    if (restart_next_) {
      restart_next_ = false;
      ++restarts_;
      return LineStatus::kRestart;
    }
    Clock::time_point slice_end{};
    if (live_ && may_idle) slice_end = Clock::now() + std::chrono::milliseconds(kIdleSliceMs);
    while (true) {
      // Complete a line from what is buffered.
      if (pos_ < len_) {
        const char* begin = buffer_.data() + pos_;
        const char* nl = static_cast<const char*>(std::memchr(begin, '\n', len_ - pos_));
        const std::size_t n = nl ? static_cast<std::size_t>(nl - begin) : len_ - pos_;
        if (nl && !HasPending()) {
          // The whole line is in the buffer: in place.
          pos_ += n + 1;
          line = std::string_view(begin, std::min(n, max_bytes));
          too_long = n > max_bytes;
          return LineStatus::kLine;
        }
        const std::size_t room = max_bytes > pending_.size() ? max_bytes - pending_.size() : 0;
        pending_.append(begin, std::min(n, room));
        if (n > room) pending_too_long_ = true;
        pos_ += n;
        if (nl) {
          ++pos_;
          return TakePending(line, too_long);
        }
      }
      if (live_) {
        if (options_.stop && options_.stop->load()) return EndOfInput(line, too_long);
        if (may_idle && Clock::now() >= slice_end) return LineStatus::kIdle;
      }
      pos_ = len_ = 0;
      const Fill got = FillBuffer(buffer_.data(), buffer_.size(), len_);
      if (got == Fill::kData) {
        if (live_) last_byte_ = Clock::now();
      } else if (got == Fill::kNothing) {
        // Idle only when a read has just found nothing: a reader that was
        // itself not scheduled for longer than the timeout (a loaded
        // machine) must not end an input whose bytes are waiting.
        if (options_.idle_timeout_s > 0 &&
            std::chrono::duration<double>(Clock::now() - last_byte_).count() > options_.idle_timeout_s) {
          return EndOfInput(line, too_long);
        }
      } else if (got == Fill::kEnd) {
        return EndOfInput(line, too_long);
      } else if (got == Fill::kBreak) {
        if (HasPending()) return TakePending(line, too_long, LineStatus::kCut);
      } else if (got == Fill::kRestart) {
        if (HasPending()) {
          restart_next_ = true;
          return TakePending(line, too_long, LineStatus::kCut);
        }
        ++restarts_;
        return LineStatus::kRestart;
      }
    }
  }

 protected:
  // Reads what is available into `buf` (its size in `len`, at most `cap`).
  // Live inputs wait a few ms at most when there is nothing (kNothing) and
  // never wait for the buffer to fill.
  virtual Fill FillBuffer(char* buf, std::size_t cap, std::size_t& len) = 0;

 private:
  bool HasPending() const { return !pending_.empty() || pending_too_long_; }
  LineStatus TakePending(std::string_view& line, bool& too_long, LineStatus status = LineStatus::kLine) {
    line = pending_;
    pending_taken_ = true;  // cleared at the next Read, when the view is dead
    too_long = pending_too_long_;
    pending_too_long_ = false;
    return status;
  }
  // A partial last line is delivered: a plain file's last line may lack its
  // '\n'; a live input's was still being written (kCut, counted as bad).
  LineStatus EndOfInput(std::string_view& line, bool& too_long) {
    if (HasPending()) return TakePending(line, too_long, live_ ? LineStatus::kCut : LineStatus::kLine);
    return LineStatus::kEnd;
  }

  bool live_;
  LiveOptions options_;
  std::vector<char> buffer_;
  std::size_t pos_{0}, len_{0};
  std::string pending_;  // the start of a line cut by the buffer's end, at most max_bytes
  bool pending_too_long_{false};
  bool pending_taken_{false};
  bool restart_next_{false};
  Clock::time_point last_byte_;
};

// A stream read to its end (tests and fuzzing give istringstreams; a
// streambuf may throw from underflow on a read error). What the stream has
// buffered is taken first, so the bytes before a failing read are lines
// like any other.
class StreamLineInput final : public BlockLineInput {
 public:
  explicit StreamLineInput(std::unique_ptr<std::istream> in) : BlockLineInput(false, {}), in_(std::move(in)) {}

 protected:
  Fill FillBuffer(char* buf, std::size_t cap, std::size_t& len) override {
    std::streambuf* sb = in_->rdbuf();
    std::streamsize n = 0;
    try {
      const std::streamsize ready = sb->in_avail();
      const auto want = static_cast<std::streamsize>(cap);
      n = sb->sgetn(buf, ready > 0 ? std::min(ready, want) : want);
    } catch (const std::exception& e) {
      throw std::runtime_error(e.what());  // the reader names the file and the line
    }
    if (n <= 0) return Fill::kEnd;
    len = static_cast<std::size_t>(n);
    return Fill::kData;
  }

 private:
  std::unique_ptr<std::istream> in_;
};

// A file read with read(2) to its end.
class FileLineInput final : public BlockLineInput {
 public:
  explicit FileLineInput(const std::string& path) : BlockLineInput(false, {}) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot open the input file");
  }
  ~FileLineInput() override { ::close(fd_); }
  FileLineInput(const FileLineInput&) = delete;
  FileLineInput& operator=(const FileLineInput&) = delete;

 protected:
  Fill FillBuffer(char* buf, std::size_t cap, std::size_t& len) override {
    while (true) {
      const ssize_t n = ::read(fd_, buf, cap);
      if (n > 0) {
        len = static_cast<std::size_t>(n);
        return Fill::kData;
      }
      if (n == 0) return Fill::kEnd;
      if (errno == EINTR) continue;
      throw std::runtime_error(std::strerror(errno));  // the reader names the file and the line
    }
  }

 private:
  int fd_{-1};
};

// The live inputs: lines as they arrive.
class LiveLineInput : public BlockLineInput {
 public:
  explicit LiveLineInput(const LiveOptions& options) : BlockLineInput(true, options) {}
};

// How often a followed file is looked at while it does not grow: the
// latency it adds, against a stat() call per poll.
constexpr auto kFollowPoll = std::chrono::milliseconds(2);

class FollowFileInput final : public LiveLineInput {
 public:
  FollowFileInput(std::string path, const LiveOptions& options) : LiveLineInput(options), path_(std::move(path)) {
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw std::runtime_error(path_ + ": cannot open the input file (" + std::strerror(errno) + ")");
  }
  ~FollowFileInput() override {
    if (fd_ >= 0) ::close(fd_);
  }

 protected:
  Fill FillBuffer(char* buf, std::size_t cap, std::size_t& len) override {
    if (restart_after_data_) {
      restart_after_data_ = false;
      return StartOver();
    }
    // Written again from its start (the acquisition program restarting its
    // test with one truncating write): the file never looked shorter, but
    // what was read is no longer there.
    if (!SameBytes(offset_)) return StartOver();
    const off_t at = offset_;
    const ssize_t n = ReadSome(buf, cap);
    if (n > 0) {
      if (!SameBytes(at)) {
        // Rewritten between the check and the read: the bytes read are the
        // new file's if the file holds them there now (read again from its
        // start), else they were the old file's last bytes (kept, then the
        // new file from its start).
        if (FileHolds(at, buf, static_cast<std::size_t>(n))) return StartOver();
        restart_after_data_ = true;
      }
      Remember(at, buf, static_cast<std::size_t>(n));
      len = static_cast<std::size_t>(n);
      return Fill::kData;
    }
    // At the end of what is written: has the file been replaced or truncated?
    struct stat now_at_path {};
    struct stat ours {};
    if (::fstat(fd_, &ours) == 0 && ::stat(path_.c_str(), &now_at_path) == 0) {
      if (now_at_path.st_ino != ours.st_ino || now_at_path.st_dev != ours.st_dev) {
        // A writer finishes the old file before it moves the new one in,
        // but its last bytes may have landed after the read above: read
        // the old file to its end first, then switch.
        const off_t last_at = offset_;
        const ssize_t last = ReadSome(buf, cap);
        if (last > 0) {
          Remember(last_at, buf, static_cast<std::size_t>(last));
          len = static_cast<std::size_t>(last);
          return Fill::kData;
        }
        const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd >= 0) {
          ::close(fd_);
          fd_ = fd;
          Forget();
          return Fill::kRestart;
        }
      } else if (ours.st_size < offset_) {
        return StartOver();
      }
    }
    std::this_thread::sleep_for(kFollowPoll);
    return Fill::kNothing;
  }

 private:
  // Bytes of the file kept to recognise it: its first kHeadBytes (a new
  // test's header and first rows differ from the old one's) and the
  // kTailBytes before the read position (what the next bytes continue).
  static constexpr std::size_t kHeadBytes = 256;
  static constexpr std::size_t kTailBytes = 64;

  ssize_t ReadSome(char* buf, std::size_t cap) {
    while (true) {
      const ssize_t n = ::read(fd_, buf, cap);
      if (n >= 0) {
        offset_ += n;
        return n;
      }
      if (errno == EINTR) continue;
      throw std::runtime_error(std::strerror(errno));  // the reader names the file and the line
    }
  }

  // Reads the file from its start again (kRestart).
  Fill StartOver() {
    if (::lseek(fd_, 0, SEEK_SET) != 0) throw std::runtime_error(std::strerror(errno));
    Forget();
    return Fill::kRestart;
  }
  void Forget() {
    offset_ = 0;
    head_.clear();
    tail_.clear();
  }

  // Keeps the head and the tail after `n` bytes read at `at`.
  void Remember(off_t at, const char* buf, std::size_t n) {
    if (static_cast<std::size_t>(at) == head_.size() && head_.size() < kHeadBytes) {
      head_.append(buf, std::min(n, kHeadBytes - head_.size()));
    }
    if (n >= kTailBytes) {
      tail_.assign(buf + n - kTailBytes, kTailBytes);
    } else {
      tail_.append(buf, n);
      if (tail_.size() > kTailBytes) tail_.erase(0, tail_.size() - kTailBytes);
    }
  }

  // Whether the file is at least `upto` bytes long and still holds the head
  // and the tail read before `upto`. A file that cannot be looked at counts
  // as the same (the read reports its error).
  bool SameBytes(off_t upto) {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) return true;
    if (st.st_size < upto) return false;
    return FileHolds(0, head_.data(), head_.size()) &&
           FileHolds(upto - static_cast<off_t>(tail_.size()), tail_.data(), tail_.size());
  }

  // Whether the file holds `want` (n bytes) at `at`.
  bool FileHolds(off_t at, const char* want, std::size_t n) {
    if (n == 0) return true;
    check_.resize(n);
    std::size_t got = 0;
    while (got < n) {
      const ssize_t r = ::pread(fd_, check_.data() + got, n - got, at + static_cast<off_t>(got));
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) return false;
      got += static_cast<std::size_t>(r);
    }
    return std::memcmp(check_.data(), want, n) == 0;
  }

  std::string path_;
  int fd_{-1};
  off_t offset_{0};
  std::string head_;  // the file's first bytes read, at most kHeadBytes
  std::string tail_;  // the bytes read just before offset_, at most kTailBytes
  std::vector<char> check_;
  bool restart_after_data_{false};
};

class TcpLineInput final : public LiveLineInput {
 public:
  TcpLineInput(std::string host, std::string port, bool listen, const LiveOptions& options)
      : LiveLineInput(options), host_(std::move(host)), port_(std::move(port)), listen_(listen) {
    if (listen_) Listen();
  }
  ~TcpLineInput() override {
    Close();
    if (listen_fd_ >= 0) ::close(listen_fd_);
  }

 protected:
  Fill FillBuffer(char* buf, std::size_t cap, std::size_t& len) override {
    if (fd_ < 0 && listen_) {
      // Listening: the acquisition PC connects (LabVIEW's TCP Open Connection).
      pollfd p{listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) return Fill::kNothing;
      fd_ = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd_ < 0) return Fill::kNothing;
      if (connected_before_) return Fill::kRestart;
      connected_before_ = true;
    }
    if (fd_ < 0) {
      const auto now = Clock::now();
      if (now < next_attempt_) {
        std::this_thread::sleep_for(std::min<Clock::duration>(next_attempt_ - now, std::chrono::milliseconds(20)));
        return Fill::kNothing;
      }
      if (!Connect()) {
        next_attempt_ = Clock::now() + backoff_;
        backoff_ = std::min<Clock::duration>(backoff_ * 2, std::chrono::seconds(5));
        return Fill::kNothing;
      }
      backoff_ = std::chrono::milliseconds(100);
      if (connected_before_) return Fill::kRestart;
      connected_before_ = true;
    }
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, 20);
    if (r <= 0) return Fill::kNothing;  // EINTR included: the caller checks its stop flag
    const ssize_t n = ::recv(fd_, buf, cap, 0);
    if (n > 0) {
      len = static_cast<std::size_t>(n);
      return Fill::kData;
    }
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) return Fill::kNothing;
    // Closed by the server or broken: reconnect after the shortest backoff.
    Close();
    next_attempt_ = Clock::now() + backoff_;
    return Fill::kBreak;
  }

 private:
  bool Connect() {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* list = nullptr;
    if (::getaddrinfo(host_.c_str(), port_.c_str(), &hints, &list) != 0 || !list) return false;
    bool ok = false;
    for (addrinfo* a = list; a && !ok; a = a->ai_next) {
      const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
      if (fd < 0) continue;
      int r = ::connect(fd, a->ai_addr, a->ai_addrlen);
      if (r != 0 && errno == EINPROGRESS) {
        pollfd p{fd, POLLOUT, 0};
        int err = 0;
        socklen_t n = sizeof err;
        r = (::poll(&p, 1, 1000) == 1 && ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &n) == 0 && err == 0) ? 0 : -1;
      }
      if (r == 0) {
        fd_ = fd;
        ok = true;
      } else {
        ::close(fd);
      }
    }
    ::freeaddrinfo(list);
    return ok;
  }
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Binds host:port (host empty, "*" or 0.0.0.0: every address) and listens.
  void Listen() {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    addrinfo* list = nullptr;
    const char* host = (host_.empty() || host_ == "*") ? nullptr : host_.c_str();
    if (::getaddrinfo(host, port_.c_str(), &hints, &list) != 0 || !list) {
      throw std::runtime_error("tcp-listen://" + host_ + ":" + port_ + ": cannot resolve the address");
    }
    std::string why = "no address";
    for (addrinfo* a = list; a && listen_fd_ < 0; a = a->ai_next) {
      const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (fd < 0) continue;
      const int one = 1;
      ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
      if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 1) == 0) {
        listen_fd_ = fd;
      } else {
        why = std::strerror(errno);
        ::close(fd);
      }
    }
    ::freeaddrinfo(list);
    if (listen_fd_ < 0) throw std::runtime_error("tcp-listen://" + host_ + ":" + port_ + ": cannot listen (" + why + ")");
  }

  std::string host_, port_;
  bool listen_{false};
  int listen_fd_{-1};
  int fd_{-1};
  bool connected_before_{false};
  Clock::duration backoff_{std::chrono::milliseconds(100)};
  Clock::time_point next_attempt_{};
};

}  // namespace

std::unique_ptr<LineInput> StreamLines(std::unique_ptr<std::istream> in) {
  return std::make_unique<StreamLineInput>(std::move(in));
}

std::unique_ptr<LineInput> FileLines(const std::string& path) {
  return std::make_unique<FileLineInput>(path);
}

std::unique_ptr<LineInput> FollowFile(const std::string& path, const LiveOptions& options) {
  return std::make_unique<FollowFileInput>(path, options);
}

std::unique_ptr<LineInput> TcpLines(const std::string& host_port, const LiveOptions& options, bool listen) {
  const std::size_t colon = host_port.rfind(':');
  if (colon == std::string::npos || (colon == 0 && !listen) || colon + 1 == host_port.size()) {
    throw std::invalid_argument("tcp://" + host_port + ": expected tcp://HOST:PORT");
  }
  std::string host = host_port.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const std::string port = host_port.substr(colon + 1);
  if (port.find_first_not_of("0123456789") != std::string::npos || port.size() > 5 || std::stoi(port) == 0 ||
      std::stoi(port) > 65535) {
    throw std::invalid_argument("tcp://" + host_port + ": the port must be a number in [1, 65535]");
  }
  return std::make_unique<TcpLineInput>(host, port, listen, options);
}

}  // namespace rocklab::daq::detail
