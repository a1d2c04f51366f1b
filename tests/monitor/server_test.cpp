// The monitor's HTTP server on 127.0.0.1 (port 0), through cpp-httplib's
// client and raw request lines, and under load (idle connections, a header
// flood, time-outs, the connection cap): it serves exactly its embedded assets with
// their types, 404 for anything else (unknown paths, directories, traversal
// attempts), 405 for methods other than GET and HEAD, the snapshot as JSON
// and the event stream (a full snapshot, then updates). Oracle: the embedded
// table (monitor/assets.h) and the LiveState fed by the test.
#include "monitor/server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <chrono>
#include <climits>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "monitor/assets.h"
#include "monitor/live_state.h"
#include "rocklab/health2_t.hpp"
#include "tests/tools/lcm_messages.h"

namespace rocklab::monitor {
namespace {

using nlohmann::json;

template <class Msg>
void FeedState(LiveState& s, const std::string& channel, const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  ASSERT_TRUE(s.Ingest(channel, b.data(), static_cast<int>(b.size())));
}

// A response whose headers and Content-Length body have arrived.
bool Complete(const std::string& response) {
  const std::size_t end = response.find("\r\n\r\n");
  if (end == std::string::npos) return false;
  const std::size_t at = response.find("Content-Length: ");
  if (at == std::string::npos || at > end) return false;  // read until the server closes
  const std::size_t length = std::stoul(response.substr(at + 16));
  return response.size() >= end + 4 + length;
}

// One request as written, one response as read (to its Content-Length, or
// until the server closes).
// Returns the status code of the response's first line, 0 if none.
int RawRequest(int port, const std::string& request, std::string* response = nullptr, long timeout_s = 10) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval timeout{timeout_s, 0};  // a bound against a hung test, not a measurement
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  std::string text;
  if (connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0 &&
      write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
    char buf[4096];
    ssize_t n = 0;
    while (!Complete(text) && (n = read(fd, buf, sizeof buf)) > 0) {
      text.append(buf, static_cast<std::size_t>(n));
    }
  }
  close(fd);
  if (response) *response = text;
  if (text.rfind("HTTP/1.1 ", 0) != 0 || text.size() < 12) return 0;
  return std::stoi(text.substr(9, 3));
}

std::string Get(const std::string& target) {
  return "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
}

class MonitorServerTest : public ::testing::Test {
 protected:
  void SetUp() override { Serve({}); }

  void Serve(ServerOptions options) {
    if (server_) server_->Stop();
    options.port = 0;
    server_ = std::make_unique<MonitorServer>(state_, options);
    server_->Start();
  }
  int port() const { return server_->port(); }

  LiveState state_;
  std::unique_ptr<MonitorServer> server_;
};

TEST_F(MonitorServerTest, BindsLoopbackAndPicksAFreePort) {
  EXPECT_EQ(ServerOptions{}.host, "127.0.0.1");
  EXPECT_GT(port(), 0);
  EXPECT_EQ(server_->url(), "http://127.0.0.1:" + std::to_string(port()) + "/");
  ServerOptions taken;
  taken.port = port();
  try {
    MonitorServer second(state_, taken);
    ADD_FAILURE() << "bound a port in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(port())), std::string::npos)
        << e.what();
  }
}

TEST_F(MonitorServerTest, ServesEveryEmbeddedAssetWithItsType) {
  std::set<std::string> paths;
  for (const Asset& a : AllAssets()) paths.insert(std::string(a.path));
  EXPECT_EQ(paths, (std::set<std::string>{"/index.html", "/app.js", "/style.css",
                                           "/uPlot.iife.min.js", "/uPlot.min.css"}));
  httplib::Client client("127.0.0.1", port());
  for (const Asset& a : AllAssets()) {
    const auto res = client.Get(std::string(a.path).c_str());
    ASSERT_TRUE(res) << a.path;
    EXPECT_EQ(res->status, 200) << a.path;
    EXPECT_EQ(res->get_header_value("Content-Type"), a.content_type) << a.path;
    EXPECT_EQ(res->body, a.body) << a.path;
    EXPECT_FALSE(a.body.empty()) << a.path;
    EXPECT_EQ(res->get_header_value("X-Content-Type-Options"), "nosniff");
  }
  const auto root = client.Get("/");
  ASSERT_TRUE(root);
  EXPECT_EQ(root->status, 200);
  EXPECT_EQ(root->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(root->body, FindAsset("/index.html")->body);
  EXPECT_NE(root->body.find("app.js"), std::string::npos);
  // Query strings do not change what is served.
  const auto query = client.Get("/app.js?v=2");
  ASSERT_TRUE(query);
  EXPECT_EQ(query->body, FindAsset("/app.js")->body);
}

TEST_F(MonitorServerTest, HeadAnswersHeadersOnly) {
  httplib::Client client("127.0.0.1", port());
  const auto res = client.Head("/app.js");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(res->body.empty());
  EXPECT_EQ(res->get_header_value("Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(res->get_header_value("Content-Length"), std::to_string(FindAsset("/app.js")->body.size()));
}

TEST_F(MonitorServerTest, UnknownPathsAndDirectoriesAre404) {
  for (const char* path : {"/nope", "/index.htm", "/app.js.map", "/favicon.ico", "/api", "/api/",
                           "/api/snapshot/x", "/API/SNAPSHOT", "/web/", "/web/index.html",
                           "/monitor/web/", "/node_modules/", "/node_modules/uplot/dist/",
                           "/uplot/dist/uPlot.iife.min.js", "//", "/./", "/index.html/"}) {
    std::string response;
    EXPECT_EQ(RawRequest(port(), Get(path), &response), 404) << path << "\n" << response;
    EXPECT_EQ(response.find("Index of"), std::string::npos) << path;
  }
}

// Whatever the spelling, a traversal attempt gets 404 or 400 and never the
// bytes of a file outside the embedded table (nor of an asset reached by an
// indirect path: there is no normalisation).
TEST_F(MonitorServerTest, TraversalAttemptsNeverServeAFile) {
  const std::string source = ROCKLAB_SOURCE_DIR;
  const std::vector<std::string> targets = {
      "/../CMakeLists.txt", "/../../../../../../etc/passwd", "/..%2f..%2f..%2fetc%2fpasswd",
      "/%2e%2e/%2e%2e/%2e%2e/etc/passwd", "/%2E%2E/%2E%2E/etc/passwd",
      "/%2F..%2F..%2F..%2Fetc%2Fpasswd", "/..%5c..%5c..%5cetc%5cpasswd", "/..\\..\\etc\\passwd",
      "/%252e%252e/%252e%252e/etc/passwd", "/.%2e/.%2e/etc/passwd", "/./app.js",
      "/web/../index.html", "/%2e/app.js", "/app.js/../index.html", "/etc/passwd",
      "//etc/passwd", "/" + source + "/CMakeLists.txt", source + "/monitor/web/index.html",
      "http://127.0.0.1/etc/passwd", "file:///etc/passwd", "/app.js%00.html",
      "/%c0%ae%c0%ae/%c0%ae%c0%ae/etc/passwd", "etc/passwd", "*"};
  for (const std::string& target : targets) {
    std::string response;
    const int status = RawRequest(port(), Get(target), &response);
    EXPECT_TRUE(status == 404 || status == 400) << target << " -> " << status << "\n" << response;
    EXPECT_EQ(response.find("root:"), std::string::npos) << target;
    EXPECT_EQ(response.find("cmake_minimum_required"), std::string::npos) << target;
    EXPECT_EQ(response.find("<!doctype html>"), std::string::npos) << target;
    EXPECT_EQ(response.find("rocklab monitor page"), std::string::npos) << target;  // app.js
  }
}

TEST_F(MonitorServerTest, MethodsOtherThanGetAndHeadAre405) {
  httplib::Client client("127.0.0.1", port());
  std::vector<httplib::Result> results;
  results.push_back(client.Post("/", "x", "text/plain"));
  results.push_back(client.Put("/app.js", "x", "text/plain"));
  results.push_back(client.Delete("/app.js"));
  results.push_back(client.Patch("/api/snapshot", "x", "text/plain"));
  results.push_back(client.Options("/"));
  results.push_back(client.Post("/nope", "x", "text/plain"));
  for (const auto& res : results) {
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 405);
    EXPECT_EQ(res->get_header_value("Allow"), "GET, HEAD");
  }
  for (const char* method : {"TRACE", "CONNECT"}) {
    std::string response;
    EXPECT_EQ(RawRequest(port(), std::string(method) +
                                     " / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
                         &response),
              405)
        << method << "\n" << response;
  }
  // A method HTTP does not define is refused by the request parser itself.
  EXPECT_EQ(RawRequest(port(), "BREW / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"), 400);
}

TEST_F(MonitorServerTest, SnapshotIsTheLiveStateAsJson) {
  FeedState(state_, "RL_THETA", test::Theta(1'000'000, 0.01));
  FeedState(state_, "RL_MODEL_fit", test::Model("fit", 1'000'000, 0.02));
  httplib::Client client("127.0.0.1", port());
  const auto res = client.Get("/api/snapshot");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store");
  const json snap = json::parse(res->body);
  EXPECT_EQ(snap.at("schema"), "rocklab.monitor.v1");
  EXPECT_EQ(snap.at("measured").at("t").size(), 1u);
  ASSERT_EQ(snap.at("variants").size(), 1u);
  EXPECT_EQ(snap.at("variants")[0].at("name"), "fit");
  EXPECT_EQ(snap.at("variants")[0].at("alpha").get<double>(), 0.235);
}

// Reads an event stream on its own thread; the test waits for its events.
class StreamReader {
 public:
  StreamReader(int port, const std::string& path) : client_("127.0.0.1", port) {
    client_.set_read_timeout(10, 0);  // a bound against a hung test
    thread_ = std::thread([this, path] {
      auto res = client_.Get(path.c_str(), [this](const char* data, std::size_t n) {
        std::lock_guard<std::mutex> lock(mutex_);
        text_.append(data, n);
        cv_.notify_all();
        return !closing_;
      });
      std::lock_guard<std::mutex> lock(mutex_);
      status_ = res ? res->status : -1;
      ended_ = true;
      cv_.notify_all();
    });
  }
  ~StreamReader() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closing_ = true;
    }
    client_.stop();
    thread_.join();
  }

  /// The `index`-th "data:" event as JSON, null if the stream ended first.
  json Event(std::size_t index) {
    std::unique_lock<std::mutex> lock(mutex_);
    std::vector<json> events;
    cv_.wait_for(lock, std::chrono::seconds(10), [&] {
      events = Parse(text_);
      return events.size() > index || ended_;
    });
    return events.size() > index ? events[index] : json();
  }
  /// Waits until the stream ends; its HTTP status.
  int EndStatus() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait_for(lock, std::chrono::seconds(10), [&] { return ended_; });
    return ended_ ? status_ : 0;
  }
  std::string text() {
    std::lock_guard<std::mutex> lock(mutex_);
    return text_;
  }

 private:
  static std::vector<json> Parse(const std::string& text) {
    std::vector<json> out;
    std::size_t pos = 0;
    for (std::size_t end; (end = text.find("\n\n", pos)) != std::string::npos; pos = end + 2) {
      const std::string block = text.substr(pos, end - pos);
      const std::size_t data = block.find("data: ");
      if (data != std::string::npos) out.push_back(json::parse(block.substr(data + 6)));
    }
    return out;
  }

  httplib::Client client_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::string text_;
  bool closing_{}, ended_{};
  int status_{};
};

// Text from the bus need not be UTF-8 (a node name, an event's detail).
// Oracle: the snapshot and the stream still answer, with U+FFFD in place of
// the invalid byte; the server process lives on.
TEST_F(MonitorServerTest, TextThatIsNotUtf8IsReplacedNotFatal) {
  rocklab::health2_t h{};
  h.utime = 1'000'000;
  h.node = "daq\xff";
  h.state = "running";
  FeedState(state_, "RL_HEALTH", h);
  httplib::Client client("127.0.0.1", port());
  const auto res = client.Get("/api/snapshot");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  const json snap = json::parse(res->body);
  ASSERT_EQ(snap.at("health").size(), 1u);
  EXPECT_EQ(snap.at("health")[0].at("node"), "daq\xef\xbf\xbd");
  StreamReader stream(port(), "/api/events");
  const json first = stream.Event(0);
  ASSERT_FALSE(first.is_null()) << stream.text();
  EXPECT_EQ(first.at("health")[0].at("node"), "daq\xef\xbf\xbd");
}

TEST_F(MonitorServerTest, EventStreamSendsTheSnapshotThenUpdates) {
  FeedState(state_, "RL_THETA", test::Theta(1'000'000, 0.01));
  StreamReader stream(port(), "/api/events");
  const json first = stream.Event(0);
  ASSERT_FALSE(first.is_null()) << stream.text();
  EXPECT_TRUE(first.at("full").get<bool>());
  EXPECT_EQ(first.at("measured").at("t").size(), 1u);
  EXPECT_NE(stream.text().find("retry: "), std::string::npos);

  FeedState(state_, "RL_THETA", test::Theta(1'100'000, 0.02));
  const json second = stream.Event(1);
  ASSERT_FALSE(second.is_null()) << stream.text();
  EXPECT_FALSE(second.at("full").get<bool>());
  ASSERT_EQ(second.at("measured").at("t").size(), 1u);  // only the new point
  EXPECT_DOUBLE_EQ(second.at("measured").at("t")[0].get<double>(), 0.1);
  EXPECT_GT(second.at("cursor").get<std::uint64_t>(), first.at("cursor").get<std::uint64_t>());
}

TEST_F(MonitorServerTest, StreamsBeyondTheLimitGet503AndStopEndsTheOthers) {
  ServerOptions one;
  one.max_streams = 1;
  Serve(one);
  StreamReader first(port(), "/api/events");
  ASSERT_FALSE(first.Event(0).is_null());
  httplib::Client client("127.0.0.1", port());
  const auto second = client.Get("/api/events");
  ASSERT_TRUE(second);
  EXPECT_EQ(second->status, 503);
  // Files and the snapshot are still served while the stream is open.
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  server_->Stop();
  EXPECT_EQ(first.EndStatus(), 200);  // the stream ended when the server stopped
}

// Connects to 127.0.0.1:port; -1 on failure.
int Connect(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// Waits up to `seconds` for the server to close `fd` (read returns 0 or an
// error); whatever it sent before is appended to `got`.
bool ClosedByServer(int fd, double seconds, std::string* got = nullptr) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char buf[4096];
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return true;
    if (got) got->append(buf, static_cast<std::size_t>(n));
  }
  return false;
}

// Connects to 127.0.0.1:port from the loopback address `from` (another
// client host, as the server sees it; 127.0.0.0/8 is all loopback);
// `rcvbuf` > 0 shrinks the client's receive buffer. -1 on failure.
int ConnectFrom(int port, const char* from, int rcvbuf = 0) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  sockaddr_in local{};
  local.sin_family = AF_INET;
  inet_pton(AF_INET, from, &local.sin_addr);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0 ||
      connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// Resident memory of this process (the server runs in it), bytes.
std::size_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

// With cpp-httplib, 1000 idle connections left a GET
// unanswered after 90 s and one client streaming header lines grew the
// process by 1.8 GB. Here 300 idle connections and a header flood are open
// while the page and the snapshot are asked for. Oracles: "answered" is a
// 200 within 30 s (the goal is well under a second, printed; starved was
// more than 90 s, so the deadline separates the two without timing
// anything finely, with room for a machine loaded by a CPU hog); the
// flooding client is cut off (431, then closed) after at most
// max_header_bytes plus what the socket buffers hold, and the process grows
// by less than 64 MB (the flood is bounded at 8 KiB per connection; 300
// connections cost their libmicrohttpd pools, 300 x 32 KiB at most).
TEST_F(MonitorServerTest, HoldsUnderIdleConnectionsAndAHeaderFlood) {
  FeedState(state_, "RL_THETA", test::Theta(1'000'000, 0.01));
  const std::size_t rss_before = ResidentBytes();
  // From five other addresses, 60 each (under the 64 per address).
  std::vector<int> idle;
  for (int i = 0; i < 300; ++i) {
    const std::string from = "127.0.0." + std::to_string(10 + i / 60);
    const int fd = ConnectFrom(port(), from.c_str());
    ASSERT_GE(fd, 0) << "connection " << i;
    idle.push_back(fd);
  }
  // Half of them have sent an unfinished request line (slow-loris style).
  for (std::size_t i = 0; i < idle.size(); i += 2) {
    ASSERT_EQ(send(idle[i], "GET / HT", 8, MSG_NOSIGNAL), 8);
  }
  std::atomic<bool> flood_cut{false};
  std::atomic<std::size_t> flood_sent{0};
  std::thread flood([this, &flood_cut, &flood_sent] {
    const int fd = Connect(port());
    if (fd < 0) return;
    const std::string start = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n";
    send(fd, start.data(), start.size(), MSG_NOSIGNAL);
    const std::string line = "X-Flood: " + std::string(100, 'a') + "\r\n";
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline) {  // bounded in time
      const ssize_t n = send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      if (n <= 0) {
        flood_cut = true;
        break;
      }
      flood_sent += static_cast<std::size_t>(n);
      if (flood_sent > (std::size_t{64} << 20)) break;  // bounded in bytes: 64 MB is "never cut off"
    }
    close(fd);
  });
  for (const char* path : {"/", "/api/snapshot"}) {
    std::string response;
    const auto start = std::chrono::steady_clock::now();
    const int status = RawRequest(port(), Get(path), &response, 60);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(status, 200) << path << "\n" << response.substr(0, 200);
    EXPECT_LT(took, 30.0) << path << ": answered, but after " << took << " s";
    std::printf("under load: GET %s answered in %.3f s\n", path, took);
  }
  flood.join();
  std::printf("under load: header flood cut off after %zu bytes; resident memory grew by %.1f MB\n",
              flood_sent.load(), (static_cast<double>(ResidentBytes()) - static_cast<double>(rss_before)) / 1e6);
  EXPECT_TRUE(flood_cut.load()) << flood_sent.load() << " bytes of header lines accepted";
  EXPECT_LT(flood_sent.load(), std::size_t{16} << 20);
  EXPECT_LT(ResidentBytes(), rss_before + (std::size_t{64} << 20));
  for (int fd : idle) close(fd);
}

// A connection that sends nothing, or half a request, is closed after
// idle_timeout_s; one beyond max_connections is refused at once; the server
// answers again when they are gone. Oracle: the options.
TEST_F(MonitorServerTest, IdleConnectionsTimeOutAndTheCapRefusesMore) {
  ServerOptions o;
  o.idle_timeout_s = 1;
  o.keepalive_period_s = 0.5;
  o.max_connections = 4;
  o.max_connections_per_host = 4;
  o.max_streams = 2;
  Serve(o);
  std::vector<int> fds;
  for (int i = 0; i < 4; ++i) fds.push_back(Connect(port()));
  ASSERT_EQ(send(fds[0], "GET / HTTP/1.1\r\nHost", 21, MSG_NOSIGNAL), 21);
  const int extra = Connect(port());  // accepted by the kernel, closed by the server
  ASSERT_GE(extra, 0);
  std::string got;
  EXPECT_TRUE(ClosedByServer(extra, 5.0, &got));
  EXPECT_TRUE(got.empty()) << got;
  close(extra);
  for (int fd : fds) {
    std::string partial;
    EXPECT_TRUE(ClosedByServer(fd, 10.0, &partial)) << "an idle connection was kept open";
    close(fd);
  }
  EXPECT_EQ(RawRequest(port(), Get("/")), 200);
}

// A header beyond max_header_bytes is refused with 431 and a close.
TEST_F(MonitorServerTest, OversizedHeaderIs431) {
  std::string response;
  const std::string big = "GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'b') + "\r\n\r\n";
  EXPECT_EQ(RawRequest(port(), big, &response), 431) << response.substr(0, 200);
}

// The status of the answer on `fd` (its first line), 0 if none within `seconds`.
int StatusOf(int fd, double seconds = 10.0) {
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char buf[256];
  while (text.find("\r\n") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  if (text.rfind("HTTP/1.1 ", 0) != 0 || text.size() < 12) return 0;
  return std::stoi(text.substr(9, 3));
}

// An event stream asked for from `from`; its socket (the caller closes it).
int OpenStream(int port, const char* from, int rcvbuf = 0) {
  const int fd = ConnectFrom(port, from, rcvbuf);
  const std::string get = "GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  if (fd >= 0) send(fd, get.data(), get.size(), MSG_NOSIGNAL);
  return fd;
}

// 8 event streams from one address denied every other
// client (503). Oracle: the options. Two streams per address: a third from
// the same address gets 503, one from another address 200.
TEST_F(MonitorServerTest, EventStreamsAreLimitedPerAddress) {
  std::vector<int> fds;
  for (int i = 0; i < 2; ++i) {
    fds.push_back(OpenStream(port(), "127.0.0.2"));
    EXPECT_EQ(StatusOf(fds.back()), 200) << "stream " << i;
  }
  fds.push_back(OpenStream(port(), "127.0.0.2"));
  EXPECT_EQ(StatusOf(fds.back()), 503);
  fds.push_back(OpenStream(port(), "127.0.0.3"));
  EXPECT_EQ(StatusOf(fds.back()), 200);
  for (int fd : fds) close(fd);
}

// Streams that read nothing give up their slots. Every
// slot is taken by clients that read nothing (a snapshot of several MB
// against a 4 KiB receive buffer: their output blocks); a client from
// another address that asks, again on a 503, gets a stream within the
// deadline, and a stalled one that gave up its slot is closed by the
// server. Oracle: the options (stream_stall_s 0.5 s; the 30 s deadlines
// only bound the test).
TEST_F(MonitorServerTest, StreamsThatDoNotReadAreDroppedForOneThatAsks) {
  ServerOptions o;
  o.max_streams = 4;
  o.max_streams_per_host = 2;
  o.stream_stall_s = 0.5;
  Serve(o);
  for (std::int64_t k = 0; k < 60000; ++k) {  // 60 s at 1 kHz, 3 series: a snapshot of about 1 MB
    const std::int64_t u = 1'000'000 + 1000 * k;
    const double theta = 1e-3 * static_cast<double>(k % 1000) + 1e-7 * static_cast<double>(k);
    FeedState(state_, "RL_THETA", test::Theta(u, theta));
    FeedState(state_, "RL_MODEL_a", test::Model("a", u, theta + 1e-4));
    FeedState(state_, "RL_MODEL_b", test::Model("b", u, theta - 1e-4));
  }
  ASSERT_GT(state_.Snapshot().dump().size(), std::size_t{400} << 10);
  std::vector<int> stalled;
  for (const char* from : {"127.0.0.2", "127.0.0.2", "127.0.0.3", "127.0.0.3"}) {
    stalled.push_back(OpenStream(port(), from, 4096));
    ASSERT_GE(stalled.back(), 0);
  }
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (status != 200 && std::chrono::steady_clock::now() < deadline) {
    const int fd = OpenStream(port(), "127.0.0.4");
    status = StatusOf(fd);
    close(fd);
    if (status != 200) std::this_thread::sleep_for(std::chrono::milliseconds(100));  // a client's retry
  }
  EXPECT_EQ(status, 200) << "a stream was refused while every slot was held by clients that read nothing";
  // The stream that gave up its slot was shut down by the server: read
  // every stalled socket (which lets the others move again) until one ends.
  std::size_t ended = 0;
  const auto read_until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  std::vector<bool> reading(stalled.size(), true);
  char buf[65536];
  while (ended == 0 && std::chrono::steady_clock::now() < read_until) {
    for (std::size_t i = 0; i < stalled.size(); ++i) {
      if (!reading[i]) continue;
      const ssize_t n = recv(stalled[i], buf, sizeof buf, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {
        reading[i] = false;
        ++ended;
      }
    }
    pollfd p{stalled[0], POLLIN, 0};
    poll(&p, 1, 10);  // pacing the loop, not a wait for a result
  }
  EXPECT_GE(ended, 1u) << "no stalled stream was dropped";
  for (int fd : stalled) close(fd);
}

// Connections trickling one header byte every 5 s held
// their slots for good (an idle timeout that each byte reset). Now the
// headers must be whole within header_timeout_s, however they trickle.
// Oracle: the options (header_timeout_s 1 s, idle_timeout_s 30 s: only the
// deadline can close it in the 10 s the test allows).
TEST_F(MonitorServerTest, AHeaderTricklingInIsCutAtItsDeadline) {
  ServerOptions o;
  o.header_timeout_s = 1;
  o.idle_timeout_s = 30;
  Serve(o);
  const int fd = Connect(port());
  ASSERT_GE(fd, 0);
  const std::string request = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + std::string(200, 's');
  const auto start = std::chrono::steady_clock::now();
  bool closed = false;
  for (std::size_t i = 0; i < request.size() && !closed; ++i) {  // at most 200 x 50 ms
    if (send(fd, &request[i], 1, MSG_NOSIGNAL) != 1) break;
    closed = ClosedByServer(fd, 0.05);
  }
  if (!closed) closed = ClosedByServer(fd, 5.0);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(closed) << "a trickling header kept its connection";
  EXPECT_LT(took, 8.0);
  close(fd);
  EXPECT_EQ(RawRequest(port(), Get("/")), 200);
}

// 8 addresses x 400 slow connections took all 1024
// slots. With 64 per address, two addresses' full shares leave room: a GET
// from a third is answered, the 65th connection of an address is closed at
// once. Oracle: the options (max_connections 160).
TEST_F(MonitorServerTest, PerAddressCapsLeaveRoomForOthers) {
  ServerOptions o;
  o.max_connections = 160;
  Serve(o);
  ASSERT_EQ(o.max_connections_per_host, 64u);
  std::vector<int> held;
  for (const char* from : {"127.0.0.2", "127.0.0.3"}) {
    for (int i = 0; i < 64; ++i) {
      held.push_back(ConnectFrom(port(), from));
      ASSERT_GE(held.back(), 0);
      send(held.back(), "G", 1, MSG_NOSIGNAL);
    }
  }
  const int extra = ConnectFrom(port(), "127.0.0.2");
  ASSERT_GE(extra, 0);
  std::string got;
  EXPECT_TRUE(ClosedByServer(extra, 5.0, &got)) << "the 65th connection of an address was kept";
  EXPECT_TRUE(got.empty()) << got;
  close(extra);
  const int fd = ConnectFrom(port(), "127.0.0.4");
  const std::string get = Get("/");
  ASSERT_EQ(send(fd, get.data(), get.size(), MSG_NOSIGNAL), static_cast<ssize_t>(get.size()));
  EXPECT_EQ(StatusOf(fd, 5.0), 200);
  close(fd);
  for (int h : held) close(h);
}

// Headers up to 11.5 KB got 200, 12 000 bytes no answer.
// Oracle: max_header_bytes = 8192 counts the request line, the header lines
// with their CRLFs and the empty line: 8192 bytes is answered, one more is
// 431, and so is every larger size up to 64 KiB.
TEST_F(MonitorServerTest, TheHeaderLimitIsExactly8KiB) {
  auto request = [](std::size_t total) {
    const std::string head = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nX-Pad: ";
    return head + std::string(total - head.size() - 4, 'p') + "\r\n\r\n";
  };
  ASSERT_EQ(request(8192).size(), 8192u);
  std::string response;
  EXPECT_EQ(RawRequest(port(), request(8192), &response), 200) << response.substr(0, 200);
  for (std::size_t total : {8193, 9000, 11500, 12000, 12300, 16384, 30000, 65536}) {
    EXPECT_EQ(RawRequest(port(), request(total), &response), 431) << total << " bytes: " << response.substr(0, 200);
  }
}

// An RL_THETA with utime near INT64_MIN became the
// monitor's time origin (one point at t = 9.2e12 s, nothing counted). Now
// it is refused and counted as a decode error of its channel; the origin is
// the first good message. Oracle: the two good messages' times.
TEST_F(MonitorServerTest, AWildUtimeDoesNotBecomeTheOrigin) {
  rocklab::block_state_t wild = test::Theta(INT64_MIN + 5, 0.5);
  std::vector<std::uint8_t> b(static_cast<std::size_t>(wild.getEncodedSize()));
  wild.encode(b.data(), 0, static_cast<int>(b.size()));
  EXPECT_FALSE(state_.Ingest("RL_THETA", b.data(), static_cast<int>(b.size())));
  FeedState(state_, "RL_THETA", test::Theta(2'000'000, 0.01));
  FeedState(state_, "RL_THETA", test::Theta(2'100'000, 0.02));
  httplib::Client client("127.0.0.1", port());
  const auto res = client.Get("/api/snapshot");
  ASSERT_TRUE(res);
  const json snap = json::parse(res->body);
  EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), 2'000'000);
  ASSERT_EQ(snap.at("measured").at("t").size(), 2u);
  EXPECT_DOUBLE_EQ(snap.at("measured").at("t")[1].get<double>(), 0.1);
  EXPECT_EQ(snap.at("counters").at("decode_errors").at("RL_THETA").get<int>(), 1);
}

TEST(MonitorServerOptions, AreValidated) {
  LiveState state;
  auto bad = [&state](auto change) {
    ServerOptions o;
    change(o);
    EXPECT_THROW(MonitorServer(state, o), std::invalid_argument);
  };
  bad([](ServerOptions& o) { o.port = -1; });
  bad([](ServerOptions& o) { o.port = 65536; });
  bad([](ServerOptions& o) { o.host = ""; });
  bad([](ServerOptions& o) { o.push_period_s = 0; });
  bad([](ServerOptions& o) { o.max_streams = 0; });
  bad([](ServerOptions& o) { o.max_connections = 0; });
  bad([](ServerOptions& o) { o.max_connections = 5000; });
  bad([](ServerOptions& o) { o.idle_timeout_s = 0.5; });
  bad([](ServerOptions& o) { o.keepalive_period_s = 20; });  // beyond the idle timeout
  bad([](ServerOptions& o) { o.max_header_bytes = 100; });
  bad([](ServerOptions& o) { o.max_connections_per_host = 0; });
  bad([](ServerOptions& o) {
    o.max_connections = 100;
    o.max_connections_per_host = 200;
  });
  bad([](ServerOptions& o) {  // more streams than connections
    o.max_connections = 100;
    o.max_streams = 200;
  });
}

}  // namespace
}  // namespace rocklab::monitor
