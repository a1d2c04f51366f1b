#include "common/bus_urls.h"

#include <array>
#include <charconv>
#include <cstdlib>
#include <stdexcept>

#include "common/text.h"

namespace rocklab::common {
namespace {

constexpr const char* kUdpm = "udpm://";
constexpr int kLcmDefaultPort = 7667;  // LCM's, when a udpm URL names none

struct UdpmAddress {
  std::array<int, 4> group{239, 255, 76, 67};  // LCM's default group
  int port{kLcmDefaultPort};
  std::string options;  // from '?' on, as given ("" when none)
};

// A decimal integer in [lo, hi] filling `text` exactly.
bool ParseInt(const std::string& text, int lo, int hi, int& out) {
  if (text.empty()) return false;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), out);
  return r.ec == std::errc{} && r.ptr == text.data() + text.size() && out >= lo && out <= hi;
}

// "udpm://[A.B.C.D[:PORT]][?OPTS]"; the errors quote the URL.
UdpmAddress ParseUdpm(const std::string& url) {
  UdpmAddress a;
  const std::string rest = url.substr(std::string(kUdpm).size());
  const auto q = rest.find('?');
  const std::string network = rest.substr(0, q);
  if (q != std::string::npos) a.options = rest.substr(q);
  if (network.empty()) return a;
  const auto colon = network.find(':');
  const std::string host = network.substr(0, colon);
  if (colon != std::string::npos && !ParseInt(network.substr(colon + 1), 1, 65535, a.port)) {
    throw std::invalid_argument("'" + url + "': the port must be in [1, 65535]");
  }
  std::size_t at = 0;
  for (int i = 0; i < 4; ++i) {
    const auto dot = i < 3 ? host.find('.', at) : host.size();
    if (dot == std::string::npos || !ParseInt(host.substr(at, dot - at), 0, 255, a.group[i])) {
      throw std::invalid_argument("'" + url + "': expected an IPv4 multicast group A.B.C.D");
    }
    at = dot + 1;
  }
  if (a.group[0] < 224 || a.group[0] > 239) {
    throw std::invalid_argument("'" + url + "': " + host + " is not an IPv4 multicast group (224.0.0.0/4)");
  }
  return a;
}

std::string ToUrl(const UdpmAddress& a) {
  return std::string(kUdpm) + std::to_string(a.group[0]) + "." + std::to_string(a.group[1]) + "." +
         std::to_string(a.group[2]) + "." + std::to_string(a.group[3]) + ":" + std::to_string(a.port) +
         a.options;
}

}  // namespace

std::string RawChannel(const std::string& prefix) { return prefix + "RAW"; }

std::string ExactChannelRegex(const std::string& channel) {
  std::string out;
  out.reserve(channel.size() + 4);
  for (char c : channel) {
    if (std::string("\\^$.|?*+()[]{}").find(c) != std::string::npos) out += '\\';
    out += c;
  }
  return out;
}

std::string ResolveLcmUrl(const std::string& url) {
  if (!url.empty()) return url;
  const char* env = std::getenv("LCM_DEFAULT_URL");
  return env != nullptr && *env != '\0' ? env : kLcmDefaultUrl;
}

std::string RawUrl(const std::string& main_url, const std::string& raw_option) {
  const std::string main = ResolveLcmUrl(main_url);
  if (raw_option == kRawUrlSame) return "";
  try {
    if (raw_option.empty()) {
      if (!StartsWith(main, kUdpm)) return "";  // memq://, file://, tcpq://: one bus
      UdpmAddress a = ParseUdpm(main);
      if (a.port == 65535) {
        throw std::invalid_argument("'" + main + "': port 65535 has no next port for the raw frames");
      }
      a.group[3] = (a.group[3] + 1) % 256;
      ++a.port;
      return ToUrl(a);
    }
    if (StartsWith(raw_option, kUdpm)) {
      const UdpmAddress raw = ParseUdpm(raw_option);
      if (StartsWith(main, kUdpm)) {
        const UdpmAddress m = ParseUdpm(main);
        if (m.port == raw.port) {
          if (m.group == raw.group) return "";  // the main bus itself
          // Linux hands both groups' datagrams to every socket bound to the
          // port once the machine joined both: the main nodes would receive
          // RL_RAW anyway, and a process on both buses every message twice.
          throw std::invalid_argument("'" + raw_option + "' shares the port " + std::to_string(m.port) +
                                      " of '" + main + "': give the raw frames a port of their own");
        }
      }
      return raw_option;
    }
    for (const char* provider : {"memq://", "file://", "tcpq://"}) {
      if (StartsWith(raw_option, provider)) return raw_option == main ? "" : raw_option;
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--raw-url: ") + e.what() +
                                (raw_option.empty() ? " (give --raw-url URL, or --raw-url same)" : ""));
  }
  throw std::invalid_argument("--raw-url: '" + raw_option +
                              "' is not an LCM URL (udpm://GROUP:PORT?OPTIONS, memq://, file://, tcpq://) "
                              "or 'same'");
}

}  // namespace rocklab::common
