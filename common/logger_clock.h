#pragma once
/// @file
/// One named stderr logger per module, and the host's monotonic clock
/// (rates, timeouts and health periods only: message times come from the
/// acquisition sample clock). Everything that logs includes this, not the
/// node loop's header.

#include <memory>
#include <string>

#include <spdlog/formatter.h>
#include <spdlog/logger.h>

namespace rocklab::common {

/// The logger named `name` from spdlog's registry, created on stderr (stdout
/// carries the commands' own output) the first time it is asked for, its
/// messages made Printable (common/text.h). Safe when two threads ask for a
/// new name at once.
std::shared_ptr<spdlog::logger> NamedLogger(const std::string& name);

/// spdlog's default pattern with the message made Printable (escaped, cut
/// at kMaxLineBytes): the formatter of every NamedLogger.
std::unique_ptr<spdlog::formatter> PrintableLogFormatter();

/// SPDLOG_LEVEL's levels (SPDLOG_LEVEL=debug, =video=debug, ...) into the
/// registry of the spdlog this code is linked with: the command's (main),
/// and each plugin's entry, whose log lines go through the shared
/// libspdlog's registry, not the command's compiled-in one
/// (tools/spdlog_fmt_implementation.cpp).
void LoadLogLevels();

/// Seconds of the host's monotonic clock (std::chrono::steady_clock), s.
double HostNowS();

}  // namespace rocklab::common
