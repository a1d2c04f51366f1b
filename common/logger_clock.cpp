#include "common/logger_clock.h"

#include <chrono>
#include <memory>
#include <string>
#include <utility>

#include <spdlog/cfg/env.h>
#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "common/progress.h"
#include "common/text.h"

namespace rocklab::common {
namespace {

// spdlog's default pattern around the message made Printable: a channel
// name, a file's header or a peer's text quoted in a warning cannot drive
// the terminal or split the log line.
class PrintableFormatter final : public spdlog::formatter {
 public:
  void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override {
    spdlog::details::log_msg safe = msg;
    const std::string text = Printable(std::string_view(msg.payload.data(), msg.payload.size()));
    safe.payload = spdlog::string_view_t(text.data(), text.size());
    pattern_.format(safe, dest);
  }
  std::unique_ptr<spdlog::formatter> clone() const override { return std::make_unique<PrintableFormatter>(); }

 private:
  spdlog::pattern_formatter pattern_;
};

// spdlog's coloured stderr sink, each line printed above a progress bar on
// stderr (Progress::PrintAbove: the bar is cleared, the line written, the
// bar redrawn), never through it.
class AboveProgressSink final : public spdlog::sinks::sink {
 public:
  void log(const spdlog::details::log_msg& msg) override {
    Progress::PrintAbove(2, [this, &msg] {
      inner_.log(msg);
      inner_.flush();
    });
  }
  void flush() override { inner_.flush(); }
  void set_pattern(const std::string& pattern) override { inner_.set_pattern(pattern); }
  void set_formatter(std::unique_ptr<spdlog::formatter> formatter) override {
    inner_.set_formatter(std::move(formatter));
  }

 private:
  spdlog::sinks::stderr_color_sink_mt inner_;
};

}  // namespace

std::unique_ptr<spdlog::formatter> PrintableLogFormatter() { return std::make_unique<PrintableFormatter>(); }

std::shared_ptr<spdlog::logger> NamedLogger(const std::string& name) {
  if (auto existing = spdlog::get(name)) return existing;
  try {
    auto logger = std::make_shared<spdlog::logger>(name, std::make_shared<AboveProgressSink>());
    spdlog::initialize_logger(logger);  // the SPDLOG_LEVEL levels; registers it
    logger->set_formatter(PrintableLogFormatter());
    return logger;
  } catch (const spdlog::spdlog_ex&) {  // another thread registered it first
    return spdlog::get(name);
  }
}

void LoadLogLevels() { spdlog::cfg::load_env_levels(); }

double HostNowS() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

}  // namespace rocklab::common
