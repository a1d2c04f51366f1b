#pragma once
// A datagram socket standing for systemd's $NOTIFY_SOCKET in the daq tests:
// bound in the test's scratch folder, reads bounded by a receive timeout (a
// bound on a wait for a condition, not a sleep).

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/daq/daq_test_util.h"

namespace rocklab::daq::test {

struct NotifySocket {
  std::string path;
  int fd{-1};
  /// Aborts the test program when the socket cannot be made (the tests
  /// would otherwise wait on nothing).
  explicit NotifySocket(const std::string& name = "notify.sock", int timeout_s = 10)
      : path(ScratchDir() + "/" + name) {
    ::unlink(path.c_str());
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path) std::abort();
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) std::abort();
    timeval timeout{timeout_s, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  }
  ~NotifySocket() { ::close(fd); }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;
  /// The next datagram, "" at the timeout.
  std::string Next() {
    char buf[256];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
  }
};

}  // namespace rocklab::daq::test
