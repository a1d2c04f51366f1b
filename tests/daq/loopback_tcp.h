#pragma once
// Loopback TCP for the live-input tests: a listener on 127.0.0.1 and a
// sender that writes a whole string (DESIGN.md: tests stay on loopback).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstddef>
#include <string>

namespace rocklab::daq::test {

/// A listening socket on 127.0.0.1 with an ephemeral port (into `port`);
/// -1 on failure.
inline int Listen(int& port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd, 1) != 0) return -1;
  socklen_t n = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &n);
  port = ntohs(addr.sin_port);
  return fd;
}

/// Sends all of `text` on `fd` (stops early when the peer has gone).
inline void SendAll(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace rocklab::daq::test
