#include "daq/daq_node.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

#include <time.h>

#include <spdlog/spdlog.h>

#include "common/bus.h"
#include "common/field_tables.h"
#include "daq/pacer.h"
#include "daq/processor.h"
#include "daq/source.h"
#include "common/logger_clock.h"
#include "common/sd_notify.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::daq {
namespace {

using Clock = std::chrono::steady_clock;

std::shared_ptr<spdlog::logger> Logger() { return common::NamedLogger("daq"); }

// steady_clock's time (CLOCK_MONOTONIC) to the kernel's tick (~4 ms behind
// at most) at a third of the cost: the heartbeat's check at every frame.
Clock::time_point DaqCoarseNow() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC_COARSE, &ts);
  return Clock::time_point(std::chrono::duration_cast<Clock::duration>(std::chrono::seconds(ts.tv_sec) +
                                                                       std::chrono::nanoseconds(ts.tv_nsec)));
}

}  // namespace

void DaqNodeConfig::Validate() const {
  if (input.empty()) throw std::invalid_argument("daq: input must name a file");
  if (!(idle_timeout_s >= 0) || !std::isfinite(idle_timeout_s)) {
    throw std::invalid_argument("daq: idle_timeout_s must be >= 0");
  }
  if (!(speed >= 0) || !std::isfinite(speed)) throw std::invalid_argument("daq: speed must be >= 0");
  if (!(config_period_s > 0)) throw std::invalid_argument("daq: config_period_s must be > 0");
  if (!(health_period_s > 0)) throw std::invalid_argument("daq: health_period_s must be > 0");
}

struct DaqNode::Impl : ProcessorSink {
  DaqNodeConfig config;
  common::Bus* bus{};  // not owned
  std::shared_ptr<spdlog::logger> log = Logger();
  std::unique_ptr<Source> source;
  std::unique_ptr<Processor> processor;
  DaqNodeStats stats;
  std::string ch_config, ch_raw, ch_table, ch_theta, ch_bodies, ch_event, ch_health;

  rocklab::daq_config2_t config_msg;
  rocklab::raw_frame_t raw_msg;
  rocklab::block_state_t theta_msg;
  rocklab::block_state2_t bodies_msg;  // RL_BODIES: a multi-body rig's every body
  rocklab::table_state_t table_msg;
  rocklab::health2_t health_msg;
  // seq of the next RL_DAQ_CONFIG, RL_EVENT, RL_HEALTH (RL_RAW, RL_THETA and
  // RL_TABLE carry the sample's own number).
  int64_t config_seq{0}, event_seq{0}, health_seq{0};

  int64_t newest_utime{0};
  Clock::time_point last_health{};
  Clock::time_point last_log{};
  int64_t suppressed_logs{0};
  int64_t health_in{0}, health_out{0};  // counts at the last health
  bool ready_sent{false};               // READY=1 went to systemd
  Pacer pacer{0};

  // Messages published since the last frame was paced. The flush at the end
  // (and after a long gap) releases up to m delayed samples at once; LCM
  // subscribers queue only 30 messages by default (lcm-logger included), so
  // when paced the node spreads such a burst: 1 ms after every kBurst.
  static constexpr int kBurst = 16;
  int burst{0};
  bool spread_bursts{false};

  template <class Msg>
  void Publish(const std::string& channel, const Msg& msg) {
    if (spread_bursts && ++burst > kBurst) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      burst = 1;
    }
    if (bus->Publish(channel, msg)) {  // encoded into the bus's reused buffer
      ++stats.published;
    } else {
      ++stats.publish_errors;
    }
  }

  void OnBlockState(const BlockState& s) override {
    common::FieldCopier<BlockState, rocklab::block_state_t> copy{s, theta_msg};
    common::BlockStateFields<rocklab::block_state_t>(copy);  // the LCM type's fields, by name
    Publish(ch_theta, theta_msg);
    if (s.body_count > 0) {
      // Beside RL_THETA (the bottom body, for every single-block consumer).
      common::BodiesCopier<BlockState, rocklab::block_state2_t> bodies{s, bodies_msg};
      common::BlockStateFields<rocklab::block_state_t>(bodies);
      bodies_msg.nbodies = s.body_count;
      Publish(ch_bodies, bodies_msg);
    }
  }

  void OnTableState(const TableState& t) override {
    common::FieldCopier<TableState, rocklab::table_state_t> copy{t, table_msg};
    common::TableStateFields<rocklab::table_state_t>(copy);
    Publish(ch_table, table_msg);
  }

  void OnEvent(const DaqEvent& e) override {
    rocklab::event2_t msg;
    msg.utime = e.utime;
    msg.seq = event_seq++;
    msg.sender = "daq";
    msg.source = "daq";
    msg.kind = e.kind;
    msg.value = e.value;
    msg.detail = e.detail;
    Publish(ch_event, msg);
  }

  void OnProblem(const Problem& p) override {
    ++stats.problems;
    // At most one log line a second; the rest are counted and summarised.
    const auto now = Clock::now();
    if (now - last_log >= std::chrono::seconds(1)) {
      if (suppressed_logs > 0) log->warn("{} more problems not shown", suppressed_logs);
      log->warn("{}", ToString(p));
      last_log = now;
      suppressed_logs = 0;
    } else {
      ++suppressed_logs;
    }
  }

  // Problems of the source itself (bad rows and values) also go out as events.
  void OnSourceProblem(const Problem& p) {
    OnProblem(p);
    OnEvent(DaqEvent{newest_utime, rocklab::event_t::BAD_SAMPLE, 1, ToString(p)});
  }

  void BuildConfigMessage() {
    const auto& names = source->channel_names();
    config_msg.rig_name = config.rig.name;
    config_msg.calibration_id = config.rig.calibration_id;
    config_msg.sample_rate_hz = source->sample_rate_hz();
    config_msg.num_channels = static_cast<int32_t>(names.size());
    config_msg.channel_names = names;
    config_msg.channel_units.clear();
    config_msg.channel_sensors.clear();
    config_msg.gain.clear();
    config_msg.offset.clear();
    for (const auto& name : names) {
      const ChannelConfig* ch = nullptr;
      for (const auto& c : config.rig.channels) {
        if (c.name == name) ch = &c;
      }
      config_msg.channel_units.push_back(ch ? ch->unit : "");
      config_msg.channel_sensors.push_back(ch ? ch->sensor : "");
      config_msg.gain.push_back(ch ? ch->gain : 1.0);
      config_msg.offset.push_back(ch ? ch->offset : 0.0);
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    config_msg.alpha = config.rig.block.alpha.value_or(nan);
    config_msg.p = config.rig.block.p.value_or(nan);
    config_msg.mu = config.rig.block.mu.value_or(nan);
  }

  // A live input waiting for its header (at the open, or after a restart):
  // the source calls this every wait slice. Under systemd the node is ready
  // once its input is open (listening, or the file open), and the heartbeat
  // and the watchdog go on while nothing arrives.
  void OnWaitingForHeader() {
    if (!ready_sent) {
      ready_sent = true;
      common::NotifySystemd("READY=1");
    }
    if (last_health == Clock::time_point{} ||
        Clock::now() - last_health >= std::chrono::duration<double>(config.health_period_s)) {
      PublishHealth("waiting for header");
    }
  }

  // RL_HEALTH. Before the source is open (waiting for its header) there are
  // no counts yet, and no sample: utime is 0.
  void PublishHealth(const char* state) {
    common::NotifyWatchdog();  // the heartbeat is the watchdog's (a no-op outside systemd)
    const auto now = Clock::now();
    const double dt = last_health == Clock::time_point{} ? 0 : std::chrono::duration<double>(now - last_health).count();
    health_msg.utime = newest_utime;
    health_msg.seq = health_seq++;
    health_msg.sender = "daq";
    health_msg.node = "daq";
    health_msg.state = state;
    health_msg.count_in = stats.frames_read;
    health_msg.count_out = stats.published;
    health_msg.rate_in_hz = dt > 0 ? (stats.frames_read - health_in) / dt : 0;
    health_msg.rate_out_hz = dt > 0 ? (stats.published - health_out) / dt : 0;
    if (processor && source) {
      const ProcessorCounts& counts = processor->counts();
      const SourceStats& src = source->stats();
      stats.gaps = processor->sequence().gaps;
      stats.missing = processor->sequence().missing;
      stats.bad_samples = src.bad_rows + src.bad_values + counts.rejected;
      stats.damaged_regions = src.damaged_regions;
      stats.damaged_bytes = src.damaged_bytes;
      stats.damaged_events = src.damaged_events;
      stats.restarts = src.restarts;
      stats.restart_lost = src.restart_lost;
    }
    health_msg.dropped = stats.missing;  // samples lost before reaching the node
    health_msg.gaps = stats.gaps;
    health_msg.bad_samples = stats.bad_samples;
    health_msg.lag_s = pacer.lag_s();
    health_in = stats.frames_read;
    health_out = stats.published + 1;  // this message
    last_health = now;
    Publish(ch_health, health_msg);
  }
};

DaqNode::DaqNode(DaqNodeConfig config, common::Bus& bus) : impl_(std::make_unique<Impl>()) {
  config.Validate();
  Impl& m = *impl_;
  m.config = std::move(config);
  m.bus = &bus;
  const std::string& p = m.config.prefix;
  m.ch_config = p + "DAQ_CONFIG";
  m.ch_raw = p + "RAW";
  m.ch_table = p + "TABLE";
  m.ch_theta = p + "THETA";
  m.ch_bodies = p + "BODIES";
  m.ch_event = p + "EVENT";
  m.ch_health = p + "HEALTH";

  SourceOptions options;
  options.sample_rate_hz = m.config.rig.sample_rate_hz;
  options.raw_channel = m.ch_raw;
  options.config_channel = m.ch_config;
  for (const auto& c : m.config.rig.channels) options.fallback_channel_names.push_back(c.name);
  Impl* impl = impl_.get();
  options.on_problem = [impl](const Problem& problem) { impl->OnSourceProblem(problem); };
  options.delimiter = m.config.delimiter;
  options.follow = m.config.follow;
  options.idle_timeout_s = m.config.idle_timeout_s;
  options.stop = m.config.stop;
  options.lcm_url = m.config.lcm_url;
  options.on_wait = [impl] { impl->OnWaitingForHeader(); };
  options.rig = &m.config.rig;
  m.source = OpenSource(m.config.input, options);
  // The units the file states against the rig's: a contradiction of a
  // channel with raw_unit stops here; one the rig leaves open is a warning.
  for (const std::string& w : CheckFileUnits(m.config.rig, m.source->channel_names(), m.source->channel_units(),
                                             m.source->path())) {
    ++m.stats.problems;
    m.log->warn("{}", w);
  }
  m.processor = std::make_unique<Processor>(m.config.rig, m.source->channel_names(),
                                            m.source->path(), m);
  // A live source arrives on its own clock: pacing it would only add latency.
  m.pacer = Pacer(m.source->live() ? 0.0 : m.config.speed);
  m.spread_bursts = m.config.speed > 0 || m.source->live();
  m.BuildConfigMessage();
}

DaqNode::~DaqNode() = default;

const DaqNodeStats& DaqNode::stats() const { return impl_->stats; }

void DaqNode::Run(const std::atomic<bool>& stop) {
  Impl& m = *impl_;
  m.last_health = Clock::now();
  // RL_HEALTH "starting" goes out with the first frame, stamped with its
  // sample clock (a message stamped 0 before an epoch-based clock would put
  // a log's first event decades before the rest).
  bool started = false;
  if (!m.ready_sent) {  // under systemd: the source is open, reading starts
    m.ready_sent = true;
    common::NotifySystemd("READY=1");
  }
  double next_config_s = std::numeric_limits<double>::quiet_NaN();
  Frame frame;
  while (true) {
    if (stop.load()) {
      m.stats.stopped_early = true;
      break;
    }
    const ReadStatus status = m.source->Next(frame);
    if (status == ReadStatus::kEnd) {
      m.stats.stopped_early = stop.load();  // a live source ends on the stop too
      break;
    }
    if (status == ReadStatus::kIdle) {  // a live source with nothing yet: the heartbeat goes on
      if (Clock::now() - m.last_health >= std::chrono::duration<double>(m.config.health_period_s)) {
        m.PublishHealth(started ? "running" : "starting");
      }
      continue;
    }
    if (status == ReadStatus::kError) {  // reported by the source; the shutdown below still runs
      m.stats.read_error = m.source->error();
      break;
    }
    if (!started) {
      started = true;
      m.newest_utime = frame.utime();
      m.PublishHealth("starting");
    }
    if (!m.pacer.WaitFor(frame.time_s, stop)) {
      // Stopped while waiting: this frame was read, so it is still published.
      m.stats.stopped_early = true;
    }
    ++m.stats.frames_read;
    m.burst = 0;
    m.newest_utime = frame.utime();
    if (!(frame.time_s < next_config_s)) {  // first frame, then every config_period_s
      m.config_msg.utime = m.newest_utime;
      m.config_msg.seq = m.config_seq++;
      m.Publish(m.ch_config, m.config_msg);
      next_config_s = frame.time_s + m.config.config_period_s;
    }
    m.raw_msg.utime = m.newest_utime;
    m.raw_msg.seq = frame.seq;
    m.raw_msg.num_channels = static_cast<int32_t>(frame.values.size());
    m.raw_msg.values.assign(frame.values.begin(), frame.values.end());
    m.Publish(m.ch_raw, m.raw_msg);
    m.processor->Process(frame);
    if (!frame.comment.empty()) {
      ++m.stats.comments;
      m.OnEvent(DaqEvent{m.newest_utime, rocklab::event_t::COMMENT, 0, frame.comment});
    }
    if (DaqCoarseNow() - m.last_health >= std::chrono::duration<double>(m.config.health_period_s)) {
      m.PublishHealth("running");
    }
    if (m.stats.stopped_early) break;
  }
  if (!started) m.PublishHealth("starting");                             // an empty input
  if (std::isnan(next_config_s)) {  // an empty input
    m.config_msg.seq = m.config_seq++;
    m.Publish(m.ch_config, m.config_msg);
  }
  common::NotifySystemd("STOPPING=1");
  m.PublishHealth("stopping");
  m.processor->Finish();
  m.PublishHealth("stopped");
  m.log->info("{}: {} frames, {} published, {} gaps ({} samples missing), {} bad samples{}",
              m.config.input, m.stats.frames_read, m.stats.published, m.stats.gaps,
              m.stats.missing, m.stats.bad_samples, m.stats.stopped_early ? " (stopped)" : "");
  if (!m.stats.read_error.empty()) m.log->error("the input was not read to its end: {}", m.stats.read_error);
}

}  // namespace rocklab::daq
