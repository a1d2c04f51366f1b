#include "monitor/server.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <httplib.h>
#include <sys/socket.h>

#include "monitor/assets.h"

namespace rocklab::monitor {
namespace {

// The page loads only its own files and talks only to its own server.
const char* const kSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; "
    "form-action 'none'";

constexpr std::size_t kMaxRequestBody = 1024;  // bytes; nothing here takes a body

// Text from the bus (node names, event details, channel names) need not be
// UTF-8: invalid bytes become U+FFFD instead of an exception in a server thread.
std::string Dump(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

void ServerOptions::Validate() const {
  auto check = [](bool ok, const char* name) {
    if (!ok) throw std::invalid_argument(std::string("monitor server option ") + name + " out of range");
  };
  check(!host.empty(), "host");
  check(port >= 0 && port <= 65535, "port");
  check(std::isfinite(push_period_s) && push_period_s > 0, "push_period_s");
  check(std::isfinite(keepalive_period_s) && keepalive_period_s > 0, "keepalive_period_s");
  check(max_streams >= 1, "max_streams");
}

struct MonitorServer::Impl {
  Impl(const LiveState& s, const ServerOptions& o) : state(s), options(o) {}

  void Routes();
  void Stream(httplib::Response& res);
  // Waits up to `seconds` or until Stop; returns false when stopping.
  bool Wait(double seconds) {
    std::unique_lock<std::mutex> lock(mutex);
    return !stop_cv.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return stopping; });
  }

  const LiveState& state;  // not owned
  const ServerOptions options;
  httplib::Server server;
  int port{};
  std::thread thread;
  std::mutex mutex;
  std::condition_variable stop_cv;
  bool stopping{};  // guarded by mutex
  std::atomic<std::size_t> streams{0};
  std::atomic<bool> listen_returned{false};
};

void MonitorServer::Impl::Routes() {
  server.set_payload_max_length(kMaxRequestBody);
  // SO_REUSEADDR only: cpp-httplib's default SO_REUSEPORT would let a second
  // monitor bind the same port and share its connections.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  server.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                              {"Content-Security-Policy", kSecurityPolicy},
                              {"Referrer-Policy", "no-referrer"},
                              {"X-Frame-Options", "DENY"}});
  // Room for every event stream plus a few workers for the files and the API.
  const std::size_t workers = options.max_streams + 4;
  server.new_task_queue = [workers] { return new httplib::ThreadPool(workers); };

  // Read-only: GET (and HEAD, which cpp-httplib answers from the GET route).
  server.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
    if (req.method == "GET" || req.method == "HEAD") return httplib::Server::HandlerResponse::Unhandled;
    res.status = 405;
    res.set_header("Allow", "GET, HEAD");
    res.set_content("method not allowed: the monitor is read-only\n", "text/plain; charset=utf-8");
    return httplib::Server::HandlerResponse::Handled;
  });

  server.Get(".*", [this](const httplib::Request& req, httplib::Response& res) {
    if (req.path == "/api/snapshot") {
      res.set_header("Cache-Control", "no-store");
      res.set_content(Dump(state.Snapshot()) + "\n", "application/json");
      return;
    }
    if (req.path == "/api/events") {
      Stream(res);
      return;
    }
    // Exact lookup in the embedded table: no file system, no normalisation.
    if (const Asset* a = FindAsset(req.path)) {
      res.set_header("Cache-Control", "no-cache");
      res.set_content(a->body.data(), a->body.size(), std::string(a->content_type).c_str());
      return;
    }
    res.status = 404;
    res.set_content("not found\n", "text/plain; charset=utf-8");
  });
}

void MonitorServer::Impl::Stream(httplib::Response& res) {
  if (streams.fetch_add(1) >= options.max_streams) {
    streams.fetch_sub(1);
    res.status = 503;
    res.set_header("Retry-After", "5");
    res.set_content("too many event streams\n", "text/plain; charset=utf-8");
    return;
  }
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");
  struct StreamState {
    bool started{};
    std::uint64_t cursor{};
    std::chrono::steady_clock::time_point last_write{};
  };
  res.set_chunked_content_provider(
      "text/event-stream",
      [this, s = StreamState{}](std::size_t, httplib::DataSink& sink) mutable {
        auto write = [&](const std::string& text) {
          s.last_write = std::chrono::steady_clock::now();
          return sink.write(text.data(), text.size());
        };
        if (!s.started) {
          s.started = true;
          const nlohmann::json full = state.UpdateSince(0);
          s.cursor = full.at("cursor").get<std::uint64_t>();
          // retry: the browser reconnects after a second when the server restarts.
          return write("retry: 1000\ndata: " + Dump(full) + "\n\n");
        }
        if (!Wait(options.push_period_s)) {
          sink.done();
          return false;
        }
        if (state.cursor() != s.cursor) {
          const nlohmann::json update = state.UpdateSince(s.cursor);
          s.cursor = update.at("cursor").get<std::uint64_t>();
          return write("data: " + Dump(update) + "\n\n");
        }
        const std::chrono::duration<double> quiet = std::chrono::steady_clock::now() - s.last_write;
        if (quiet.count() >= options.keepalive_period_s) return write(": quiet\n\n");
        return true;
      },
      [this](bool) { streams.fetch_sub(1); });
}

MonitorServer::MonitorServer(const LiveState& state, const ServerOptions& options) {
  options.Validate();
  impl_ = std::make_unique<Impl>(state, options);
  impl_->Routes();
  const std::string where = options.host + ":" + std::to_string(options.port);
  if (options.port == 0) {
    impl_->port = impl_->server.bind_to_any_port(options.host);
    if (impl_->port <= 0) throw std::runtime_error("cannot listen on " + where);
  } else {
    if (!impl_->server.bind_to_port(options.host, options.port)) {
      throw std::runtime_error("cannot listen on " + where + " (in use, or not an address of this host)");
    }
    impl_->port = options.port;
  }
}

MonitorServer::~MonitorServer() { Stop(); }

void MonitorServer::Start() {
  if (impl_->thread.joinable()) return;
  impl_->listen_returned = false;
  impl_->thread = std::thread([this] {
    impl_->server.listen_after_bind();
    impl_->listen_returned = true;
  });
  // cpp-httplib's stop() does nothing before the server runs: wait for it, so
  // that a Stop() right after Start() cannot leave the thread in accept().
  while (!impl_->server.is_running() && !impl_->listen_returned) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void MonitorServer::Stop() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stopping = true;
  }
  impl_->stop_cv.notify_all();
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

int MonitorServer::port() const { return impl_->port; }

std::string MonitorServer::url() const {
  const std::string& host = impl_->options.host;
  const bool ipv6 = host.find(':') != std::string::npos;
  return "http://" + (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(impl_->port) + "/";
}

}  // namespace rocklab::monitor
