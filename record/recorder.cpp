#include "record/recorder.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "common/logger_clock.h"
#include "common/versions.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::record {
namespace {

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> logger = common::NamedLogger("record");
  return logger;
}

RotationOptions Rotation(const RecorderOptions& o) {
  RotationOptions r;
  r.path = o.out_path;
  r.rotate_bytes = o.rotate_bytes;
  r.rotate_seconds = o.rotate_seconds;
  r.overwrite = o.overwrite;
  return r;
}

const RecorderOptions& Validated(const RecorderOptions& o) {
  o.Validate();
  return o;
}

RotationOptions WriterRotation(const RecorderOptions& o) {
  RotationOptions r = Rotation(o);
  if (o.provenance != nullptr) o.provenance->Attach(r);
  return r;
}

}  // namespace

void RecorderOptions::Validate() const {
  Rotation(*this).Validate();
  if (channels.empty()) throw std::invalid_argument("--channels must be a non-empty LCM channel regex");
  if (queue_bytes < (1u << 16)) {
    throw std::invalid_argument("--queue-mb: the queue must hold at least 64 KiB, got " +
                                std::to_string(queue_bytes) + " bytes");
  }
  if (lcm_queue_messages < 1) throw std::invalid_argument("lcm_queue_messages must be >= 1");
}

Recorder::Recorder(lcm::LCM& instance, RecorderOptions options)
    : Recorder(std::vector<lcm::LCM*>{&instance}, std::move(options)) {}

Recorder::Recorder(const std::vector<lcm::LCM*>& lcms, RecorderOptions options)
    : options_(Validated(options)), queue_(options_.queue_bytes), writer_(WriterRotation(options_)) {
  if (lcms.empty()) throw std::invalid_argument("the recorder needs an LCM instance");
  names_.reserve(64);
  produced_.reserve(64);
  written_.reserve(64);
  for (lcm::LCM* instance : lcms) {
    lcm::Subscription* sub = instance->subscribeFunction(options_.channels, &Recorder::OnMessage, this);
    if (!sub) {
      for (auto& [subscribed, s] : subscriptions_) subscribed->unsubscribe(s);
      throw std::runtime_error("cannot subscribe to '" + options_.channels + "'");
    }
    sub->setQueueCapacity(options_.lcm_queue_messages);
    subscriptions_.emplace_back(instance, sub);
  }
  thread_ = std::thread([this] { WriterLoop(); });
}

Recorder::~Recorder() { Stop(); }

void Recorder::OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Recorder* self) {
  // LCM's thread: find the channel's id (a new channel costs one allocation,
  // its first event), copy the event into the queue, count.
  int32_t id = 0;
  const auto it = self->ids_.find(channel);
  if (it != self->ids_.end()) {
    id = it->second;
  } else {
    // No exception may cross LCM's C code: a channel that cannot be added
    // (out of memory) is counted as a drop.
    try {
      id = static_cast<int32_t>(self->names_.size());
      self->names_.push_back(channel);
      self->produced_.emplace_back();
      self->ids_.emplace(channel, id);
    } catch (const std::exception&) {
      self->names_.resize(static_cast<std::size_t>(id));
      self->produced_.resize(static_cast<std::size_t>(id));
      ++self->drops_total_;
      ++self->unregistered_drops_;
      return;
    }
  }
  ProducerChannel& c = self->produced_[static_cast<std::size_t>(id)];
  ++c.received;
  if (!self->queue_.Push(id, rbuf->recv_utime, channel, rbuf->data, rbuf->data_size)) {
    ++c.dropped;
    ++self->drops_total_;
  }
}

void Recorder::WriterLoop() {
  using std::chrono::milliseconds;
  bool failing = false;
  const auto write = [&](const EventView& ev) {
    const auto id = static_cast<std::size_t>(ev.channel_id);
    while (written_.size() <= id) written_.emplace_back();  // ids are dense: at most once per channel
    ChannelStats& c = written_[id];
    if (c.name.empty()) c.name.assign(ev.channel.data(), ev.channel.size());
    if (!writer_.Write(ev.utime, ev.channel, ev.data, ev.size)) {
      ++c.dropped;
      write_failures_.fetch_add(1, std::memory_order_relaxed);
      if (!failing) Log()->error("writing the log failed: {} (events are counted as dropped)", writer_.error());
      failing = true;
      return;
    }
    failing = false;
    ++c.count;
    c.bytes += ev.size;
    // Every rocklab type's seq (per sender on RL_EVENT and RL_HEALTH).
    int64_t seq = 0;
    std::string_view sender;
    if (!common::WireSeq(ev.data, static_cast<int>(ev.size), seq, sender)) return;
    c.seq.Add(sender, seq);
  };
  // The file is flushed at most 100 ms after an event is written, so readers
  // of a growing log (and a test waiting for its probe) see it.
  bool dirty = false;
  double last_flush = common::HostNowS();
  uint64_t damaged_seen = 0;
  while (true) {
    const int n = queue_.PopBatch(write, milliseconds(50));
    const EventQueue::Damage damage = queue_.damage();
    if (damage.records > damaged_seen) {
      damaged_seen = damage.records;
      Log()->error("the event queue's memory was damaged: {} events ({} bytes) given up so far, counted as dropped",
                   damage.events, damage.bytes);
    }
    if (n < 0) break;
    dirty = dirty || n > 0;
    const double now = common::HostNowS();
    if (dirty && (n == 0 || now - last_flush >= 0.1)) {
      if (!writer_.Flush() && !failing) {
        Log()->error("flushing the log failed: {}", writer_.error());
        failing = true;
      }
      dirty = false;
      last_flush = now;
    }
  }
  if (!writer_.Close()) Log()->error("closing the log failed: {}", writer_.error());
}

void Recorder::Stop() {
  if (stopped_) return;
  stopped_ = true;
  for (auto& [instance, sub] : subscriptions_) instance->unsubscribe(sub);
  subscriptions_.clear();
  queue_.Close();
  if (thread_.joinable()) thread_.join();
}

int64_t Recorder::DropsSince() {
  const int64_t total = drops_total_ + write_failures_.load(std::memory_order_relaxed);
  const int64_t n = total - drops_reported_;
  drops_reported_ = total;
  return n;
}

RecorderStats Recorder::Stats() const {
  RecorderStats s;
  for (std::size_t i = 0; i < names_.size(); ++i) {
    ChannelStats c;
    if (stopped_ && i < written_.size()) c = written_[i];
    c.name = names_[i];
    c.received = produced_[i].received;
    c.dropped += produced_[i].dropped;
    s.received += c.received;
    s.events += c.count;
    s.dropped += c.dropped;
    s.channels.push_back(c);
  }
  if (stopped_) {
    s.files = writer_.files();
    s.bytes = writer_.bytes();
    s.write_error = writer_.error();
  }
  s.dropped += unregistered_drops_;
  s.queue_damaged_events = static_cast<int64_t>(queue_.damage().events);
  s.dropped += s.queue_damaged_events;
  s.queue_bytes = queue_.capacity_bytes();
  s.queue_high_water_bytes = queue_.high_water_bytes();
  return s;
}

std::string SummaryJson(const RecorderStats& s) {
  nlohmann::json j;
  j["files"] = s.files;
  j["events"] = s.events;
  j["received"] = s.received;
  j["dropped"] = s.dropped;
  j["bytes"] = s.bytes;
  j["queue_bytes"] = s.queue_bytes;
  j["queue_high_water_bytes"] = s.queue_high_water_bytes;
  j["queue_damaged_events"] = s.queue_damaged_events;
  j["write_error"] = s.write_error;
  int64_t gaps = 0, missing = 0;
  nlohmann::json channels = nlohmann::json::array();
  for (const ChannelStats& c : s.channels) {
    channels.push_back({{"name", c.name},
                        {"count", c.count},
                        {"received", c.received},
                        {"dropped", c.dropped},
                        {"bytes", c.bytes},
                        {"has_seq", c.seq.any},
                        {"seq_gaps", c.seq.gaps},
                        {"seq_missing", c.seq.missing},
                        {"seq_back", c.seq.back},
                        {"seq_late", c.seq.late},
                        {"seq_duplicates", c.seq.duplicates},
                        {"seq_restarts", c.seq.restarts},
                        {"seq_wild", c.seq.wild}});
    gaps = common::SeqGaps::SaturatingAdd(gaps, c.seq.gaps);
    missing = common::SeqGaps::SaturatingAdd(missing, c.seq.missing);
  }
  j["seq_gaps"] = gaps;
  j["seq_missing"] = missing;
  j["channels"] = channels;
  j["units"] = {{"bytes", "bytes"}, {"queue_bytes", "bytes"}, {"queue_high_water_bytes", "bytes"}};
  return j.dump(2) + "\n";
}

}  // namespace rocklab::record
