#pragma once
/// @file
/// Where the raw frames go: the one place that derives the LCM URL of the
/// raw channel (RL_RAW, raw_frame_t, one per acquisition frame: the largest
/// and most frequent messages) from the main bus's URL and `--raw-url`.
///
/// By default a udpm main URL `udpm://A.B.C.D:PORT?OPTS` sends RL_RAW to
/// `udpm://A.B.C.(D+1):(PORT+1)?OPTS`, a group and a port of its own, so
/// nodes that never read it do not receive it; any other provider keeps
/// RL_RAW on the main bus, as does `--raw-url same`. A raw URL that would
/// share the main sockets is refused or merged (never two instances on one
/// socket address). The rule, its edge cases and why both group and port
/// change: docs/channels.md.

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
