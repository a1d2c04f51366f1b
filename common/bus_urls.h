#pragma once
/// @file
/// Where the raw frames go: the one place that derives the LCM URL of the
/// raw channel (RL_RAW, raw_frame_t, one per acquisition frame: the largest
/// and most frequent messages) from the main bus's URL and `--raw-url`.
///
/// The default keeps RL_RAW off the main udpm group, so that nodes that never
/// read it (model, compare, monitor) do not receive it:
///  - main `udpm://A.B.C.D:PORT?OPTS` -> raw `udpm://A.B.C.(D+1):(PORT+1)?OPTS`
///    (LCM's default udpm://239.255.76.67:7667?ttl=0 -> udpm://239.255.76.68:7668?ttl=0).
///    D = 255 wraps to 0; PORT 65535 has no successor (an error: give --raw-url).
///    Both change: a group of its own keeps the frames off the wire to hosts
///    that never join it (with IGMP snooping), a port of its own keeps them
///    out of the main sockets on a host where some process joined the raw
///    group (Linux delivers a group's datagrams to every socket bound to the
///    port on INADDR_ANY, as LCM's are, once any socket on the host joined it;
///    measured in docs/performance.md, "Raw frames on their own group");
///  - any other provider (memq://, file://, tcpq://): the main bus itself.
/// `--raw-url URL` names the raw bus; `--raw-url same` keeps RL_RAW on the
/// main bus (the behaviour before the split). A raw udpm URL on the main
/// URL's group and port is the main bus (never two instances on one socket
/// address: a subscriber would receive every message twice); on the main
/// URL's port with another group it is refused (for the reason above, the
/// main sockets would receive it, and `rocklab record` on both buses wrote
/// every message twice).

#include <string>

namespace rocklab::common {

/// LCM's own default URL (when neither a URL nor LCM_DEFAULT_URL is given).
inline constexpr const char* kLcmDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";
/// `--raw-url same`: RL_RAW on the main bus.
inline constexpr const char* kRawUrlSame = "same";

/// The raw channel for a channel prefix: prefix + "RAW" (RL_RAW).
std::string RawChannel(const std::string& prefix = "RL_");

/// A regex (LCM's and std::regex's syntax) matching exactly `channel`: each
/// of \^$.|?*+()[]{} escaped.
std::string ExactChannelRegex(const std::string& channel);

/// `url`, or when empty LCM_DEFAULT_URL (when set and not empty), else
/// kLcmDefaultUrl: the URL an LCM instance opened with `url` uses.
std::string ResolveLcmUrl(const std::string& url);

/// The raw bus's URL for the main bus `main_url` (empty: ResolveLcmUrl's)
/// and `raw_option` (--raw-url: empty = derived as the file comment says,
/// "same", or a URL). Returns "" when RL_RAW goes on the main bus.
/// @throws std::invalid_argument starting "--raw-url: " naming the URL: a
///         raw URL that is not an LCM URL (udpm://, memq://, file://,
///         tcpq://), a udpm URL without an IPv4 group or with a bad port,
///         a udpm URL on the main URL's port with another group, a main udpm
///         URL no raw URL can be derived from.
std::string RawUrl(const std::string& main_url, const std::string& raw_option);

}  // namespace rocklab::common
