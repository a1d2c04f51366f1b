#include "monitor/server.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <microhttpd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <list>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "monitor/assets.h"

namespace rocklab::monitor {
namespace {

// The page loads only its own files and talks only to its own server.
const char* const kSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; "
    "form-action 'none'";

const char* const kTextPlain = "text/plain; charset=utf-8";

// Text from the bus (node names, event details, channel names) need not be
// UTF-8: invalid bytes become U+FFFD instead of an exception in a server thread.
std::string Dump(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// Methods HTTP/1.1 defines (RFC 9110 and PATCH): 405 for these, 400 for any
// other token, as cpp-httplib answered before.
bool IsHttpMethod(std::string_view m) {
  for (const char* known : {"GET", "HEAD", "POST", "PUT", "DELETE", "CONNECT", "OPTIONS", "TRACE", "PATCH"}) {
    if (m == known) return true;
  }
  return false;
}

// Paths are looked up exactly as sent: no percent-decoding, so "%2e%2e" and
// "%00" stay what they are and find nothing in the embedded table.
size_t KeepEscapes(void*, MHD_Connection*, char* uri) { return std::strlen(uri); }

// A client's address as a key (the address bytes, without the port).
std::string HostKey(MHD_Connection* connection) {
  const MHD_ConnectionInfo* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
  if (info == nullptr || info->client_addr == nullptr) return {};
  const sockaddr* a = info->client_addr;
  if (a->sa_family == AF_INET) {
    const auto* in = reinterpret_cast<const sockaddr_in*>(a);
    return std::string(reinterpret_cast<const char*>(&in->sin_addr), sizeof in->sin_addr);
  }
  if (a->sa_family == AF_INET6) {
    const auto* in6 = reinterpret_cast<const sockaddr_in6*>(a);
    return std::string(reinterpret_cast<const char*>(&in6->sin6_addr), sizeof in6->sin6_addr);
  }
  return {};
}

int ConnectionFd(MHD_Connection* connection) {
  const MHD_ConnectionInfo* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CONNECTION_FD);
  return info == nullptr ? -1 : info->connect_fd;
}

// The file-descriptor head room the server leaves to the rest of the process
// (LCM sockets, logs) below the open-file limit.
constexpr std::size_t kSpareDescriptors = 64;

}  // namespace

struct MonitorServer::Impl {
  // One event stream: owned by its libmicrohttpd response (freed by its free
  // callback), listed in `streams` while the response lives.
  struct Stream {
    Impl* impl{};
    MHD_Connection* connection{};  // not owned
    bool started{};
    bool suspended{};              // guarded by impl->mutex
    std::atomic<bool> due{false};  // a push period passed since the last look
    std::uint64_t cursor{};
    std::string host;              // HostKey of its client
    int fd{-1};                    // its socket (libmicrohttpd's)
    bool dropped{};                // cut off for not reading; guarded by impl->mutex
    // When libmicrohttpd last asked for output: while the stream is not
    // parked, a socket that takes nothing leaves this behind. Guarded by mutex.
    std::chrono::steady_clock::time_point last_asked{};
    std::chrono::steady_clock::time_point last_write{};
    std::string out;  // the message being sent (one snapshot or update at most)
    std::size_t out_pos{};
    std::list<Stream*>::iterator entry;
  };

  // One open connection, for the header deadline: created and freed by
  // libmicrohttpd's connection notifications (its socket context).
  struct Conn {
    int fd{-1};
    bool in_header{true};  // waiting for a request's line and headers
    bool cut{};            // shut down for missing the deadline
    std::chrono::steady_clock::time_point header_start;
    std::list<Conn*>::iterator entry;
  };

  Impl(const LiveState& s, const ServerOptions& o) : state(s), options(o) {}
  ~Impl() {
    if (listen_fd >= 0) close(listen_fd);
  }

  static MHD_Result Handle(void* cls, MHD_Connection* connection, const char* url, const char* method,
                           const char* version, const char* upload_data, size_t* upload_data_size,
                           void** request);
  MHD_Result Answer(MHD_Connection* connection, std::string_view url, std::string_view method);
  MHD_Result StartStream(MHD_Connection* connection);
  static ssize_t ReadStream(void* cls, uint64_t pos, char* buf, size_t max);
  static void FreeStream(void* cls);
  static void NotifyConnection(void* cls, MHD_Connection* connection, void** socket_context,
                               MHD_ConnectionNotificationCode code);
  static void Completed(void* cls, MHD_Connection* connection, void** request, MHD_RequestTerminationCode code);
  void Tick();
  void CutLateHeaders();

  // Queues a response carrying the default headers.
  MHD_Result Queue(MHD_Connection* connection, unsigned status, MHD_Response* response) {
    MHD_add_response_header(response, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(response, "Content-Security-Policy", kSecurityPolicy);
    MHD_add_response_header(response, "Referrer-Policy", "no-referrer");
    MHD_add_response_header(response, "X-Frame-Options", "DENY");
    const MHD_Result r = MHD_queue_response(connection, status, response);
    MHD_destroy_response(response);
    return r;
  }
  MHD_Result Text(MHD_Connection* connection, unsigned status, const char* text) {
    MHD_Response* r = MHD_create_response_from_buffer(std::strlen(text), const_cast<char*>(text),
                                                      MHD_RESPMEM_PERSISTENT);
    if (r == nullptr) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", kTextPlain);
    return Queue(connection, status, r);
  }

  const LiveState& state;  // not owned
  const ServerOptions options;
  int listen_fd{-1};  // ours until Start hands it to libmicrohttpd
  int port{};
  MHD_Daemon* daemon{};
  std::thread ticker;

  std::mutex mutex;
  std::condition_variable stop_cv;
  bool stopping{};             // guarded by mutex
  std::list<Stream*> streams;  // guarded by mutex
  std::condition_variable streams_cv;
  std::list<Conn*> conns;      // guarded by mutex
};

// Connections are listed from accept to close; shutdown(2) of a late one's
// socket (under the mutex, so before NotifyConnection's "closed", after
// which libmicrohttpd closes the descriptor) makes libmicrohttpd close it.
void MonitorServer::Impl::NotifyConnection(void* cls, MHD_Connection* connection, void** socket_context,
                                           MHD_ConnectionNotificationCode code) {
  Impl& self = *static_cast<Impl*>(cls);
  std::lock_guard<std::mutex> lock(self.mutex);
  if (code == MHD_CONNECTION_NOTIFY_STARTED) {
    auto* c = new Conn;
    c->fd = ConnectionFd(connection);
    c->header_start = std::chrono::steady_clock::now();
    self.conns.push_front(c);
    c->entry = self.conns.begin();
    *socket_context = c;
  } else if (code == MHD_CONNECTION_NOTIFY_CLOSED && *socket_context != nullptr) {
    auto* c = static_cast<Conn*>(*socket_context);
    self.conns.erase(c->entry);
    delete c;
    *socket_context = nullptr;
  }
}

// A request answered (or abandoned): the next one's headers have their own deadline.
void MonitorServer::Impl::Completed(void* cls, MHD_Connection* connection, void**, MHD_RequestTerminationCode) {
  Impl& self = *static_cast<Impl*>(cls);
  const MHD_ConnectionInfo* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
  if (info == nullptr || info->socket_context == nullptr) return;
  std::lock_guard<std::mutex> lock(self.mutex);
  auto* c = static_cast<Conn*>(info->socket_context);
  c->in_header = true;
  c->header_start = std::chrono::steady_clock::now();
}

// Called with the mutex held.
void MonitorServer::Impl::CutLateHeaders() {
  const auto now = std::chrono::steady_clock::now();
  const auto deadline = std::chrono::duration<double>(options.header_timeout_s);
  for (Conn* c : conns) {
    if (c->in_header && !c->cut && c->fd >= 0 && now - c->header_start > deadline) {
      shutdown(c->fd, SHUT_RDWR);
      c->cut = true;
    }
  }
}

MHD_Result MonitorServer::Impl::Handle(void* cls, MHD_Connection* connection, const char* url,
                                       const char* method, const char*, const char*,
                                       size_t* upload_data_size, void** request) {
  Impl& self = *static_cast<Impl*>(cls);
  if (*request == nullptr) {
    // First call, with the headers: answer now (nothing here reads a body).
    *request = &self;
    const MHD_ConnectionInfo* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    if (info != nullptr && info->socket_context != nullptr) {
      std::lock_guard<std::mutex> lock(self.mutex);
      static_cast<Conn*>(info->socket_context)->in_header = false;
    }
    const MHD_ConnectionInfo* size = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_REQUEST_HEADER_SIZE);
    if (size != nullptr && size->header_size > self.options.max_header_bytes) {
      MHD_Response* r = MHD_create_response_from_buffer(std::strlen("request header too large\n"),
                                                        const_cast<char*>("request header too large\n"),
                                                        MHD_RESPMEM_PERSISTENT);
      if (r == nullptr) return MHD_NO;
      MHD_add_response_header(r, "Content-Type", kTextPlain);
      MHD_add_response_header(r, "Connection", "close");
      return self.Queue(connection, 431, r);
    }
    return self.Answer(connection, url, method);
  }
  *upload_data_size = 0;  // a body after an answer was queued: discarded
  return MHD_YES;
}

MHD_Result MonitorServer::Impl::Answer(MHD_Connection* connection, std::string_view url,
                                       std::string_view method) {
  if (method != "GET" && method != "HEAD") {
    if (!IsHttpMethod(method)) return Text(connection, 400, "bad request\n");
    MHD_Response* r = MHD_create_response_from_buffer(
        std::strlen("method not allowed: the monitor is read-only\n"),
        const_cast<char*>("method not allowed: the monitor is read-only\n"), MHD_RESPMEM_PERSISTENT);
    if (r == nullptr) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", kTextPlain);
    MHD_add_response_header(r, "Allow", "GET, HEAD");
    return Queue(connection, 405, r);
  }
  if (url == "/api/snapshot") {
    const std::string body = Dump(state.Snapshot()) + "\n";
    MHD_Response* r = MHD_create_response_from_buffer(body.size(), const_cast<char*>(body.data()),
                                                      MHD_RESPMEM_MUST_COPY);
    if (r == nullptr) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", "application/json");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    return Queue(connection, 200, r);
  }
  if (url == "/api/events") return StartStream(connection);
  // Exact lookup in the embedded table: no file system, no normalisation.
  const Asset* a = FindAsset(std::string(url));
  if (a == nullptr) return Text(connection, 404, "not found\n");
  MHD_Response* r = MHD_create_response_from_buffer(a->body.size(), const_cast<char*>(a->body.data()),
                                                    MHD_RESPMEM_PERSISTENT);
  if (r == nullptr) return MHD_NO;
  MHD_add_response_header(r, "Content-Type", std::string(a->content_type).c_str());
  MHD_add_response_header(r, "Cache-Control", "no-cache");
  return Queue(connection, 200, r);
}

MHD_Result MonitorServer::Impl::StartStream(MHD_Connection* connection) {
  auto stream = std::make_unique<Stream>();
  stream->host = HostKey(connection);
  stream->fd = ConnectionFd(connection);
  if (stream->fd >= 0) {
    // A bounded send buffer (the kernel doubles it): what a stream can park
    // in the kernel stays small, and a client that reads nothing blocks its
    // stream within a snapshot or a few updates, so it shows as stalled.
    const int bytes = 32 * 1024;
    setsockopt(stream->fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
  }
  {
    std::lock_guard<std::mutex> lock(mutex);
    // Streams whose clients read nothing give up their slots first.
    const auto now = std::chrono::steady_clock::now();
    const auto stall = std::chrono::duration<double>(options.stream_stall_s);
    const std::size_t per_host = std::min(options.max_streams_per_host, options.max_streams);
    std::size_t open = 0, from_host = 0;
    for (Stream* other : streams) {
      if (other->dropped) continue;
      ++open;
      if (other->host == stream->host) ++from_host;
    }
    if (open >= options.max_streams || from_host >= per_host) {
      for (Stream* other : streams) {
        if (open < options.max_streams && from_host < per_host) break;
        const bool counts = open >= options.max_streams || other->host == stream->host;
        if (other->dropped || other->suspended || !counts || now - other->last_asked < stall) continue;
        other->dropped = true;  // libmicrohttpd closes it on its next look at the socket
        if (other->fd >= 0) shutdown(other->fd, SHUT_RDWR);
        --open;
        if (other->host == stream->host) --from_host;
      }
    }
    if (stopping || open >= options.max_streams || from_host >= per_host) {
      MHD_Response* r = MHD_create_response_from_buffer(std::strlen("too many event streams\n"),
                                                        const_cast<char*>("too many event streams\n"),
                                                        MHD_RESPMEM_PERSISTENT);
      if (r == nullptr) return MHD_NO;
      MHD_add_response_header(r, "Content-Type", kTextPlain);
      MHD_add_response_header(r, "Retry-After", "5");
      return Queue(connection, 503, r);
    }
    stream->impl = this;
    stream->connection = connection;
    stream->last_asked = now;
    streams.push_front(stream.get());
    stream->entry = streams.begin();
  }
  Stream* s = stream.release();  // owned by the response from here
  // 4 KiB blocks: a snapshot goes out in pieces as the socket takes them.
  MHD_Response* r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, &ReadStream, s, &FreeStream);
  if (r == nullptr) {
    FreeStream(s);
    return MHD_NO;
  }
  MHD_add_response_header(r, "Content-Type", "text/event-stream");
  MHD_add_response_header(r, "Cache-Control", "no-store");
  MHD_add_response_header(r, "X-Accel-Buffering", "no");
  return Queue(connection, 200, r);
}

// Called by the polling thread whenever the socket can take more. Returns the
// bytes copied, 0 after suspending the connection until the next tick, or
// the end of the stream once the server stops.
ssize_t MonitorServer::Impl::ReadStream(void* cls, uint64_t, char* buf, size_t max) {
  Stream& s = *static_cast<Stream*>(cls);
  Impl& self = *s.impl;
  {
    std::lock_guard<std::mutex> lock(self.mutex);
    s.last_asked = std::chrono::steady_clock::now();
  }
  if (s.out_pos >= s.out.size()) {
    s.out.clear();
    s.out_pos = 0;
    {
      std::lock_guard<std::mutex> lock(self.mutex);
      if (self.stopping) return MHD_CONTENT_READER_END_OF_STREAM;
    }
    if (!s.started) {
      s.started = true;
      const nlohmann::json full = self.state.UpdateSince(0);
      s.cursor = full.at("cursor").get<std::uint64_t>();
      // retry: the browser reconnects after a second when the server restarts.
      s.out = "retry: 1000\ndata: " + Dump(full) + "\n\n";
    } else if (s.due.exchange(false)) {
      if (self.state.cursor() != s.cursor) {
        const nlohmann::json update = self.state.UpdateSince(s.cursor);
        s.cursor = update.at("cursor").get<std::uint64_t>();
        s.out = "data: " + Dump(update) + "\n\n";
      } else {
        const std::chrono::duration<double> quiet = std::chrono::steady_clock::now() - s.last_write;
        if (quiet.count() >= self.options.keepalive_period_s) s.out = ": quiet\n\n";
      }
    }
    if (s.out.empty()) {
      // Nothing to send: park the connection until the ticker resumes it.
      std::lock_guard<std::mutex> lock(self.mutex);
      if (self.stopping) return MHD_CONTENT_READER_END_OF_STREAM;
      s.suspended = true;
      MHD_suspend_connection(s.connection);
      return 0;
    }
    s.last_write = std::chrono::steady_clock::now();
  }
  const std::size_t n = std::min(max, s.out.size() - s.out_pos);
  std::memcpy(buf, s.out.data() + s.out_pos, n);
  s.out_pos += n;
  return static_cast<ssize_t>(n);
}

void MonitorServer::Impl::FreeStream(void* cls) {
  Stream* s = static_cast<Stream*>(cls);
  Impl& self = *s->impl;
  {
    std::lock_guard<std::mutex> lock(self.mutex);
    self.streams.erase(s->entry);
  }
  self.streams_cv.notify_all();
  delete s;
}

// Once per push period: every parked stream looks at the state again.
void MonitorServer::Impl::Tick() {
  std::unique_lock<std::mutex> lock(mutex);
  while (!stopping) {
    stop_cv.wait_for(lock, std::chrono::duration<double>(options.push_period_s), [this] { return stopping; });
    const auto now = std::chrono::steady_clock::now();
    for (Stream* s : streams) {
      s->due = true;
      if (s->suspended) {
        s->suspended = false;
        s->last_asked = now;  // parked until now: not blocked
        MHD_resume_connection(s->connection);
      }
    }
    CutLateHeaders();
  }
}

MonitorServer::MonitorServer(const LiveState& state, const ServerOptions& options) {
  options.Validate();
  impl_ = std::make_unique<Impl>(state, options);
  const std::string where = options.host + ":" + std::to_string(options.port);
  // The listening socket is made here, so that the port is known (and taken)
  // before Start, and with SO_REUSEADDR only: SO_REUSEPORT would let a second
  // monitor bind the same port and share its connections.
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (getaddrinfo(options.host.c_str(), std::to_string(options.port).c_str(), &hints, &found) != 0 ||
      found == nullptr) {
    throw std::runtime_error("cannot listen on " + where + " (not an address of this host)");
  }
  int fd = -1;
  for (addrinfo* a = found; a != nullptr && fd < 0; a = a->ai_next) {
    fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    if (bind(fd, a->ai_addr, a->ai_addrlen) != 0 || listen(fd, 128) != 0) {
      close(fd);
      fd = -1;
    }
  }
  freeaddrinfo(found);
  if (fd < 0) throw std::runtime_error("cannot listen on " + where + " (in use, or not an address of this host)");
  impl_->listen_fd = fd;
  sockaddr_storage bound{};
  socklen_t len = sizeof bound;
  getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len);
  impl_->port = bound.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port)
                                            : ntohs(reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
}

MonitorServer::~MonitorServer() { Stop(); }

void MonitorServer::Start() {
  Impl& m = *impl_;
  if (m.daemon != nullptr || m.listen_fd < 0) return;
  // Connections beyond the open-file limit would fail at accept() anyway;
  // leave the rest of the process its descriptors.
  std::size_t limit = m.options.max_connections;
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur != RLIM_INFINITY) {
    const std::size_t room = files.rlim_cur > kSpareDescriptors + 1 ? files.rlim_cur - kSpareDescriptors : 1;
    limit = std::min(limit, room);
  }
  const auto timeout_s = static_cast<unsigned>(std::ceil(m.options.idle_timeout_s));
  // libmicrohttpd keeps the request line and headers in the connection's
  // memory pool; the response headers need a little room beside them.
  // Twice the limit and more: a header just over it is still read whole and
  // answered 431 here (libmicrohttpd answers 431 itself, when it can, only
  // beyond its pool).
  const std::size_t pool = 2 * m.options.max_header_bytes + 16384;
  m.daemon = MHD_start_daemon(
      MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME, 0, nullptr, nullptr,
      &Impl::Handle, &m,  //
      MHD_OPTION_LISTEN_SOCKET, m.listen_fd,                            //
      MHD_OPTION_CONNECTION_LIMIT, static_cast<unsigned>(limit),        //
      MHD_OPTION_PER_IP_CONNECTION_LIMIT,
      static_cast<unsigned>(std::min(limit, m.options.max_connections_per_host)),  //
      MHD_OPTION_CONNECTION_TIMEOUT, timeout_s,                         //
      MHD_OPTION_CONNECTION_MEMORY_LIMIT, pool,                         //
      MHD_OPTION_UNESCAPE_CALLBACK, &KeepEscapes, nullptr,              //
      MHD_OPTION_NOTIFY_CONNECTION, &Impl::NotifyConnection, &m,        //
      MHD_OPTION_NOTIFY_COMPLETED, &Impl::Completed, &m,                //
      MHD_OPTION_END);
  if (m.daemon == nullptr) throw std::runtime_error("cannot start the HTTP server on " + url());
  m.ticker = std::thread([&m] { m.Tick(); });
}

void MonitorServer::Stop() {
  Impl& m = *impl_;
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    m.stopping = true;
    // Every parked stream wakes up, sees `stopping` and ends (libmicrohttpd
    // must not be stopped with a connection suspended).
    for (Impl::Stream* s : m.streams) {
      if (s->suspended) {
        s->suspended = false;
        MHD_resume_connection(s->connection);
      }
    }
  }
  m.stop_cv.notify_all();
  if (m.ticker.joinable()) m.ticker.join();
  if (m.daemon == nullptr) return;
  {
    // Give the streams' last chunks a moment to leave (a client that reads
    // nothing is cut off when the daemon stops).
    std::unique_lock<std::mutex> lock(m.mutex);
    m.streams_cv.wait_for(lock, std::chrono::seconds(2), [&m] { return m.streams.empty(); });
  }
  MHD_quiesce_daemon(m.daemon);
  MHD_stop_daemon(m.daemon);
  m.daemon = nullptr;
  close(m.listen_fd);  // after the stop, as libmicrohttpd's manual asks
  m.listen_fd = -1;
}

int MonitorServer::port() const { return impl_->port; }

std::string MonitorServer::url() const {
  const std::string& host = impl_->options.host;
  const bool ipv6 = host.find(':') != std::string::npos;
  return "http://" + (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(impl_->port) + "/";
}

}  // namespace rocklab::monitor
