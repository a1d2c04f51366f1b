// LiveState: options, the public calls and the lock around them. The state
// is in live_state_impl.h, ingesting in live_ingest.cpp, the JSON in
// live_json.cpp.
#include "monitor/live_state.h"

#include <stdexcept>

#include "monitor/live_state_impl.h"

namespace rocklab::monitor {

using namespace live_detail;  // NOLINT(google-build-using-namespace): the private helpers of live_state_impl.h

void LiveOptions::Validate() const {
  auto check = [](bool ok, const char* name) {
    if (!ok) throw std::invalid_argument(std::string("monitor option ") + name + " out of range");
  };
  check(window_s > 0 && !std::isnan(window_s), "window_s");
  check(std::isfinite(series_rate_hz) && series_rate_hz > 0, "series_rate_hz");
  check(!std::isfinite(window_s) || window_s * series_rate_hz < 1e8, "window_s * series_rate_hz");
  check(max_events >= 1, "max_events");
  check(max_intervals >= 1, "max_intervals");
  check(max_variants >= 1, "max_variants");
  check(max_nodes >= 1, "max_nodes");
  check(max_channels >= 1, "max_channels");
  check(max_points == 0 || max_points >= 16, "max_points");
  check(from_s >= 0 && std::isfinite(from_s), "from_s");
  check(to_s > from_s && !std::isnan(to_s), "to_s");
  check(std::isfinite(new_record_after_s) && new_record_after_s > 0, "new_record_after_s");
}

LiveState::LiveState(const LiveOptions& options) : options_(options) {
  options_.Validate();
  impl_ = std::make_unique<Impl>(options_);
}

LiveState::~LiveState() = default;

bool LiveState::Ingest(const std::string& channel, const void* data, int size) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!data || size < 0) size = 0;
  return impl_->Ingest(channel, data ? data : "", size);
}

nlohmann::json LiveState::Snapshot() const { return UpdateSince(0); }

nlohmann::json LiveState::UpdateSince(std::uint64_t cursor) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return impl_->Update(cursor);
}

std::uint64_t LiveState::cursor() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return impl_->seq;
}

std::size_t LiveState::SeriesCapacity() const { return impl_->grows ? 0 : impl_->capacity; }

}  // namespace rocklab::monitor
