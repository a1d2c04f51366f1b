#include "record/log_provenance.h"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <system_error>

#include <spdlog/spdlog.h>

#include "common/logger_clock.h"

namespace rocklab::record {

LogProvenance::LogProvenance(std::vector<std::string> sources, Fields extra) : extra_(std::move(extra)) {
  worker_ = std::thread([this, s = std::move(sources)]() mutable { Work(std::move(s)); });
}

LogProvenance::~LogProvenance() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  worker_.join();
}

void LogProvenance::Attach(RotationOptions& options) {
  series_ = options.path;
  options.on_started = [this](const std::string& path) { Started(path); };
  options.on_finished = [this](const FinishedLogFile& file) { Finished(file); };
}

LogProvenance::Fields LogProvenance::FieldsOf(const Queued& q) {
  const FinishedLogFile& file = q.file;
  common::Provenance p;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    p = provenance_;
  }
  p.created_utc = common::UtcText(q.finished);
  Fields fields = common::ProvenanceFields(p);
  fields.insert(fields.end(), extra_.begin(), extra_.end());
  fields.emplace_back("log_series", series_);
  fields.emplace_back("log_file_index", std::to_string(file.index));
  fields.emplace_back("first_event", std::to_string(file.first_event));
  fields.emplace_back("events", std::to_string(file.events));
  fields.emplace_back("bytes", std::to_string(file.bytes));
  fields.emplace_back("first_utime_us", std::to_string(file.first_utime));
  fields.emplace_back("last_utime_us", std::to_string(file.last_utime));
  return fields;
}

void LogProvenance::Started(const std::string& path) {
  // A sidecar left by an earlier recording of this name (--force) must not
  // pass for this one's while it is being written.
  std::error_code ec;
  std::filesystem::remove(common::ProvenanceSidecarPath(path), ec);
}

void LogProvenance::Finished(const FinishedLogFile& file) {
  Queued q{file, std::time(nullptr)};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(std::move(q));
  }
  wake_.notify_one();
}

void LogProvenance::Work(std::vector<std::string> sources) {
  // The hashing first (it may read a large input file), then the sidecars
  // as the files finish.
  common::Provenance hashed;
  try {
    hashed = common::MakeProvenance(sources);
  } catch (const std::exception& e) {  // the sidecars say what they can
    errors_.fetch_add(1);
    common::NamedLogger("record")->error("the provenance of the log's sources could not be made: {}", e.what());
    hashed = common::MakeProvenance({});
  }
  std::unique_lock<std::mutex> lock(mutex_);
  provenance_ = std::move(hashed);
  have_provenance_ = true;
  drained_.notify_all();
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stopping, nothing left
    Queued q = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    try {
      common::WriteProvenanceSidecarFields(q.file.path, FieldsOf(q));
    } catch (const std::exception& e) {
      errors_.fetch_add(1);
      common::NamedLogger("record")->error("{}: its provenance sidecar could not be written: {}", q.file.path,
                                           e.what());
    }
    lock.lock();
    busy_ = false;
    if (queue_.empty()) drained_.notify_all();
  }
}

void LogProvenance::Drain() {
  std::unique_lock<std::mutex> lock(mutex_);
  drained_.wait(lock, [this] { return have_provenance_ && queue_.empty() && !busy_; });
}

int64_t LogProvenance::errors() {
  Drain();
  return errors_.load();
}

}  // namespace rocklab::record
