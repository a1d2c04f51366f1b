#include "record/log_provenance.h"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <system_error>

#include <spdlog/spdlog.h>

#include "common/logger_clock.h"

namespace rocklab::record {

LogProvenance::LogProvenance(std::vector<std::string> sources, Fields extra) : extra_(std::move(extra)) {
  hashing_ = std::async(std::launch::async, [s = std::move(sources)] { return common::MakeProvenance(s); });
}

LogProvenance::~LogProvenance() {
  if (hashing_.valid()) hashing_.wait();
}

void LogProvenance::Attach(RotationOptions& options) {
  series_ = options.path;
  options.on_started = [this](const std::string& path) { Started(path); };
  options.on_finished = [this](const FinishedLogFile& file) { Finished(file); };
}

LogProvenance::Fields LogProvenance::FieldsOf(const FinishedLogFile& file) {
  if (!have_provenance_) {
    provenance_ = hashing_.get();
    have_provenance_ = true;
  }
  common::Provenance p = provenance_;
  p.created_utc = common::MakeProvenance({}).created_utc;  // when this file was finished
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
  try {
    common::WriteProvenanceSidecarFields(file.path, FieldsOf(file));
  } catch (const std::exception& e) {
    errors_.fetch_add(1);
    common::NamedLogger("record")->error("{}: its provenance sidecar could not be written: {}", file.path, e.what());
  }
}

}  // namespace rocklab::record
