#include "model/model_node.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <spdlog/spdlog.h>

#include "common/node_support.h"
#include "model/model_registry.h"
#include "model/numbers.h"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"

namespace rocklab::model {
namespace {

using common::HostNowS;

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> log = common::NamedLogger("model_node");
  return log;
}

std::int8_t RegimeCode(Regime r) {
  switch (r) {
    case Regime::kRest: return rocklab::model_state3_t::REGIME_REST;
    case Regime::kRocking: return rocklab::model_state3_t::REGIME_ROCKING;
    case Regime::kOverturned: return rocklab::model_state3_t::REGIME_OVERTURNED;
  }
  return rocklab::model_state3_t::REGIME_REST;
}

std::int8_t EquationsCode(Equations e) {
  switch (e) {
    case Equations::kHousner: return rocklab::model_state3_t::EQUATIONS_HOUSNER;
    case Equations::kEq10: return rocklab::model_state3_t::EQUATIONS_EQ10;
    case Equations::kLimit: return rocklab::model_state3_t::EQUATIONS_LIMIT;
  }
  return rocklab::model_state3_t::EQUATIONS_UNKNOWN;
}

std::int8_t EventCode(EventKind k) {
  switch (k) {
    case EventKind::kUplift: return rocklab::event_t::UPLIFT;
    case EventKind::kImpact: return rocklab::event_t::IMPACT;
    case EventKind::kRest: return rocklab::event_t::REST;
    case EventKind::kOverturn: return rocklab::event_t::OVERTURN;
  }
  return rocklab::event_t::REST;
}

// The node's interpolant of the held samples (docs/models.md, "Lookahead":
// measured against the chord on exact and noisy accelerations).
constexpr SampleWindow::Shape kWindowShape = SampleWindow::Shape::kCubic;

// Held samples beyond the lookahead: the integrator evaluates the forcing
// from the last output on, whose interval's cubic reads one sample before
// it (3 would do; 8 leaves room).
constexpr int kWindowSpare = 8;
constexpr int kMaxLookahead = 65536;

const ModelNodeConfig& Validated(const ModelNodeConfig& config) {
  config.Validate();
  return config;
}

}  // namespace

void ModelNodeConfig::Validate() const {
  if (variants.empty() && ensembles.empty()) {
    throw std::invalid_argument("model node: no variant or ensemble configured");
  }
  for (std::size_t i = 0; i < ensembles.size(); ++i) {
    ensembles[i].Validate();
    for (std::size_t j = 0; j < i; ++j) {
      if (ensembles[i].name == ensembles[j].name) {
        throw std::invalid_argument("model node: ensemble name '" + ensembles[i].name + "' used twice");
      }
    }
  }
  for (std::size_t i = 0; i < variants.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (variants[i].name == variants[j].name) {
        throw std::invalid_argument("model node: variant name '" + variants[i].name + "' used twice");
      }
    }
  }
  if (!(rest_threshold_rad >= 0) || !std::isfinite(rest_threshold_rad)) {
    throw std::invalid_argument("model node option rest_threshold_rad out of range");
  }
  if (!(health_period_s > 0) || !std::isfinite(health_period_s)) {
    throw std::invalid_argument("model node option health_period_s out of range");
  }
  if (subscriber_queue < 1) throw std::invalid_argument("model node option subscriber_queue out of range");
  if (threads < 0) throw std::invalid_argument("model node option threads out of range");
  if (lookahead_samples < 0 || lookahead_samples > kMaxLookahead) {
    throw std::invalid_argument("model node option lookahead_samples out of range (0 .. " +
                                std::to_string(kMaxLookahead) + ")");
  }
}

// One model stepped on the samples: a variant's, or an ensemble member.
struct ModelNode::Runner {
  std::string label;  // for the log: "variant 'x'", "ensemble 'e' draw 3 (line 5)"
  std::unique_ptr<RockingModel> model;  // a single block's; null for a stack
  std::unique_ptr<stack::Stepper> stack;  // a stack's (an assembly variant of two or more bodies)
  bool failed{};
  bool failed_now{};   // failed at the sample being stepped (logged by the handler)
  std::string error;   // its message
};

struct ModelNode::Variant {
  VariantSpec spec;
  Runner run;
  std::string channel;
  rocklab::model_state3_t msg{};  // its seq: the next message's number on `channel`
  rocklab::model_state4_t bodies_msg{};  // a stack's message instead (its seq likewise)
  std::vector<std::string> interface_names;  // a stack's, for its events: "table/drum1", ...
  double stack_energy_scale_j{1.0};  // a stack's M g R of its bottom body on its base corner, J
};

struct ModelNode::Ensemble {
  EnsembleSpec spec;
  std::vector<Runner> members;
  std::string channel;
  rocklab::model_band_t msg{};  // its seq: the next message's number on `channel`
  std::vector<double> thetas;   // the members' theta at the sample (capacity: K)
  std::vector<double> sigmas;   // their draws' noise sigma, rad (all 0: none in the file)
  bool noisy{};                 // the draws have a noise sigma: the band is of a measurement
};

// Worker threads 1 .. n-1 of the variant stepping (thread 0 is the
// handler's). A sample is a generation: Run publishes it, each worker steps
// its variants and counts down `pending_`, Run waits for zero. A worker
// waits by spinning for up to kSpinS (at --max the next sample comes
// after the handler's own share and the other nodes' work, a few
// microseconds) and then blocks (live, samples are a millisecond apart).
// A spin shorter than that gap put a futex sleep and wake on every sample
// (docs/performance.md, "Issue 33, sixth round").
class ModelNode::Workers {
 public:
  Workers(ModelNode& node, int threads) : node_(node), threads_(threads) {
    for (int w = 1; w < threads_; ++w) pool_.emplace_back([this, w] { Loop(w); });
  }
  ~Workers() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    for (std::thread& t : pool_) t.join();
  }
  Workers(const Workers&) = delete;
  Workers& operator=(const Workers&) = delete;

  // Steps every variant to the sample; returns when all are done.
  void Run(const Target& target) {
    target_ = target;
    pending_.store(threads_ - 1, std::memory_order_relaxed);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      generation_.fetch_add(1, std::memory_order_release);
    }
    if (sleepers_.load(std::memory_order_acquire) > 0) wake_.notify_all();
    Share(0);
    Spinner spinner;
    while (pending_.load(std::memory_order_acquire) > 0) {
      if (!spinner.Spin()) std::this_thread::yield();
    }
  }

 private:
  // How long a waiting thread polls before it blocks (the worker) or
  // yields (the handler), s.
  static constexpr double kSpinS = 50e-6;

  // Polls with the CPU's pause hint; Spin() is false once kSpinS has
  // passed (the clock read every 64 polls).
  class Spinner {
   public:
    bool Spin() {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
      if ((++polls_ & 63) != 0) return true;
      const auto now = std::chrono::steady_clock::now();
      if (polls_ == 64) start_ = now;
      return now - start_ < std::chrono::duration<double>(kSpinS);
    }

   private:
    unsigned polls_{0};
    std::chrono::steady_clock::time_point start_{};
  };

  void Share(int w) {
    for (std::size_t i = static_cast<std::size_t>(w); i < node_.runners_.size();
         i += static_cast<std::size_t>(threads_)) {
      node_.StepRunner(i, target_);
    }
  }
  void Loop(int w) {
    std::uint64_t seen = 0;
    while (true) {
      std::uint64_t now = generation_.load(std::memory_order_acquire);
      for (Spinner spinner; now == seen && spinner.Spin();) now = generation_.load(std::memory_order_acquire);
      if (now == seen) {
        std::unique_lock<std::mutex> lock(mutex_);
        sleepers_.fetch_add(1, std::memory_order_acq_rel);
        wake_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
        sleepers_.fetch_sub(1, std::memory_order_acq_rel);
        now = generation_.load(std::memory_order_acquire);
      }
      seen = now;
      if (quit_) return;
      Share(w);
      pending_.fetch_sub(1, std::memory_order_acq_rel);
    }
  }

  ModelNode& node_;
  const int threads_;
  std::vector<std::thread> pool_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> pending_{0};
  std::atomic<int> sleepers_{0};
  bool quit_{false};  // written under mutex_ before the generation it ends
  // The sample of the current generation (written before it is published).
  Target target_{};
};

ModelNode::ModelNode(const ModelNodeConfig& config, common::Bus& bus)
    : config_(Validated(config)),
      bus_(bus),
      window_(config.lookahead_samples + kWindowSpare, kWindowShape),
      held_utime_(static_cast<std::size_t>(config.lookahead_samples) + 1) {
  for (const VariantSpec& spec : config_.variants) {
    auto v = std::make_unique<Variant>();
    v->spec = spec;
    ModelOptions options = spec.options;
    options.integrator = config_.integrator;
    v->run.label = "variant '" + spec.name + "'";
    v->channel = config_.channel_prefix + "MODEL_" + spec.name;
    if (spec.stack) {
      InitStackVariant(*v, options);
      variants_.push_back(std::move(v));
      continue;
    }
    v->run.model = RockingModel::Create(spec.kind, spec.params, options);
    v->msg.name = spec.name;
    v->msg.model = ToString(spec.kind);
    v->msg.alpha = spec.params.alpha;
    v->msg.p = spec.params.p;
    v->msg.mu = spec.params.mu;
    v->msg.l = FindModel(spec.kind).has_l ? spec.options.l : 0.0;
    variants_.push_back(std::move(v));
  }
  for (const EnsembleSpec& spec : config_.ensembles) {
    auto e = std::make_unique<Ensemble>();
    e->spec = spec;
    e->channel = config_.channel_prefix + "BAND_" + spec.name;
    e->members.resize(spec.draws.size());
    for (std::size_t k = 0; k < spec.draws.size(); ++k) {
      const PosteriorDraw& d = spec.draws[k];
      ModelOptions options = spec.options;
      options.integrator = config_.integrator;
      if (std::isfinite(d.l)) options.l = d.l;  // the draw's own l (complex formulation)
      e->members[k].label = "ensemble '" + spec.name + "' draw " + std::to_string(k) + " (" + spec.source +
                            ":" + std::to_string(d.line) + ")";
      e->members[k].model = RockingModel::Create(spec.kind, d.params, options);
    }
    e->thetas.reserve(spec.draws.size());
    e->sigmas.reserve(spec.draws.size());
    e->noisy = spec.draws.front().sigma > 0;  // the file has the column for every row or none
    e->msg.name = spec.name;
    e->msg.model = ToString(spec.kind);
    e->msg.draws = static_cast<std::int32_t>(spec.draws.size());
    ensembles_.push_back(std::move(e));
  }
  for (auto& v : variants_) runners_.push_back(&v->run);
  for (auto& e : ensembles_) {
    for (Runner& m : e->members) runners_.push_back(&m);
  }
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int threads = std::min(static_cast<int>(runners_.size()), config_.threads > 0 ? config_.threads : cores);
  if (threads > 1) workers_ = std::make_unique<Workers>(*this, threads);
  sender_ = "model:" + (variants_.empty() ? ensembles_.front()->spec.name : variants_.front()->spec.name);
  event_channel_ = config_.channel_prefix + "EVENT";
  health_channel_ = config_.channel_prefix + "HEALTH";
  last_health_host_s_ = HostNowS();
  subscriptions_.push_back(bus_.Subscribe<rocklab::table_state_t>(
      config_.channel_prefix + "TABLE",
      [this](const std::string&, const rocklab::table_state_t& m) { HandleTable(m); },
      config_.subscriber_queue));
  subscriptions_.push_back(bus_.Subscribe<rocklab::block_state_t>(
      config_.channel_prefix + "THETA",
      [this](const std::string&, const rocklab::block_state_t& m) { HandleTheta(m); },
      config_.subscriber_queue));
  // RL_BODIES only for a stack's start: a single-block node does not decode it.
  if (std::any_of(variants_.begin(), variants_.end(), [](const auto& v) { return v->run.stack != nullptr; })) {
    subscriptions_.push_back(bus_.Subscribe<rocklab::block_state2_t>(
        config_.channel_prefix + "BODIES",
        [this](const std::string&, const rocklab::block_state2_t& m) { HandleBodies(m); },
        config_.subscriber_queue));
  }
}

ModelNode::~ModelNode() {
  subscriptions_.clear();  // no handler runs from here on
  workers_.reset();  // joins the workers before the variants go
}

std::size_t ModelNode::variant_count() const { return variants_.size(); }

const rocklab::model_state3_t& ModelNode::latest(std::size_t i) const { return variants_.at(i)->msg; }

const rocklab::model_state4_t& ModelNode::latest_bodies(std::size_t i) const { return variants_.at(i)->bodies_msg; }

const rocklab::model_band_t& ModelNode::band(std::size_t i) const { return ensembles_.at(i)->msg; }

void ModelNode::Start(const rocklab::block_state_t& theta, std::int64_t start_utime) {
  const bool at_rest = !std::isfinite(theta.theta) || std::abs(theta.theta) < config_.rest_threshold_rad;
  const double theta0 = at_rest ? 0.0 : theta.theta;
  const double theta_dot0 = at_rest || !std::isfinite(theta.theta_dot) ? 0.0 : theta.theta_dot;
  for (Runner* r : runners_) {
    try {
      if (r->stack) {
        r->stack->Reset(0.0);  // a stack starts at rest (docs/models.md, "The model node")
      } else {
        r->model->Reset(0.0, theta0, theta_dot0);
        r->model->ClearEvents();
      }
      r->failed = false;
    } catch (const std::exception& e) {
      r->failed = true;
      ++failures_;
      Log()->error("{}: reset failed: {}", r->label, e.what());
    }
  }
  for (auto& v : variants_) {
    if (v->run.stack && !v->run.failed) StartStack(*v, theta.utime);
  }
  started_ = true;
  start_utime_ = start_utime;
  Log()->info("variants start at utime {} from theta {:.5f} rad{}", start_utime, theta0,
              at_rest ? " (at rest)" : "");
}

void ModelNode::StartStack(Variant& v, std::int64_t theta_utime) {
  if (!have_bodies_) return;  // a single-block rig: at rest
  Runner& r = v.run;
  const int n = r.stack->stack().bodies();
  std::string refused;
  if (last_bodies_.utime != theta_utime) {
    refused = "RL_BODIES of utime " + std::to_string(last_bodies_.utime) + " is not the starting sample's (" +
              std::to_string(theta_utime) + ")";
  } else if (last_bodies_.nbodies != n) {
    refused = "RL_BODIES carries " + std::to_string(last_bodies_.nbodies) + " bodies, the stack " + std::to_string(n);
  } else {
    // The stack's sign: counter-clockwise positive.
    std::array<double, stack::kMaxBodies> theta{}, theta_dot{};
    for (std::size_t k = 0; k < static_cast<std::size_t>(n); ++k) {
      theta[k] = 0.0 - last_bodies_.theta[k];
      theta_dot[k] = 0.0 - last_bodies_.theta_dot[k];
    }
    try {
      refused = r.stack->ResetFrom(0.0, theta.data(), theta_dot.data(), config_.rest_threshold_rad);
    } catch (const std::exception& e) {
      refused = e.what();
      r.stack->Reset(0.0);
    }
  }
  if (refused.empty()) {
    Log()->info("{} starts from RL_BODIES in mode {}", r.label, stack::ModeName(r.stack->mode(), n));
    return;
  }
  ++start_refusals_;
  Log()->warn("{}: measured start refused, at rest instead: {}", r.label, refused);
  PublishEvent(last_bodies_.utime, rocklab::event_t::BAD_SAMPLE, 1,
               "variant " + v.spec.name + ": measured start refused (" + refused + "): the stack starts at rest");
}

void ModelNode::HandleBodies(const rocklab::block_state2_t& msg) {
  bodies_seq_.Add(msg.seq);
  Bodies& b = last_bodies_;
  b.utime = msg.utime;
  b.nbodies = msg.nbodies;
  b.theta.fill(std::nan(""));
  b.theta_dot.fill(std::nan(""));
  const std::size_t n = std::min({static_cast<std::size_t>(std::max(msg.nbodies, 0)), b.theta.size(),
                                  msg.theta.size(), msg.theta_dot.size()});
  std::copy_n(msg.theta.begin(), n, b.theta.begin());
  std::copy_n(msg.theta_dot.begin(), n, b.theta_dot.begin());
  have_bodies_ = true;
}

void ModelNode::HandleTheta(const rocklab::block_state_t& msg) {
  theta_seq_.Add(msg.seq);
  last_theta_ = msg;  // plain data and short strings: no allocation
  have_theta_ = true;
}

void ModelNode::PublishEvent(std::int64_t utime, std::int8_t kind, double value,
                             const std::string& detail) {
  rocklab::event2_t ev;
  ev.utime = utime;
  ev.seq = event_seq_++;
  ev.sender = sender_;
  ev.source = "model";
  ev.kind = kind;
  ev.value = value;
  ev.detail = detail;
  bus_.Publish(event_channel_, ev);
}

void ModelNode::HandleTable(const rocklab::table_state_t& msg) {
  if (last_table_utime_ != INT64_MIN && msg.utime <= last_table_utime_) {
    if (msg.utime == last_table_utime_) return;  // duplicate: the DAQ already counted it
    FlushHeld();  // the old run's held samples, before its variants go
    ++resets_;
    started_ = false;
    have_theta_ = have_theta_ && last_theta_.utime <= msg.utime;  // an old run's theta cannot start it
    have_bodies_ = have_bodies_ && last_bodies_.utime <= msg.utime;
    Log()->info("table time went back from {} to {} us: reset", last_table_utime_, msg.utime);
  }
  // Gaps: a forward jump of RL_TABLE's seq (the DAQ numbers every sample).
  table_seq_.Add(msg.seq);
  last_table_utime_ = msg.utime;
  ++table_count_;
  // A bad (non-finite) sample: hold the last finite acceleration, count it,
  // report the first of each stretch.
  double accel = msg.acceleration;
  if (!std::isfinite(accel)) {
    ++bad_table_samples_;
    ++bad_in_stretch_;
    accel = held_accel_mps2_;
    if (!in_bad_stretch_) {
      in_bad_stretch_ = true;
      PublishEvent(msg.utime, rocklab::event_t::BAD_SAMPLE, 1,
                   "table acceleration is not finite: the models hold the last value");
    }
  } else {
    if (in_bad_stretch_) {
      in_bad_stretch_ = false;
      PublishEvent(msg.utime, rocklab::event_t::RECOVERED, 0,
                   "table acceleration finite again after " + std::to_string(bad_in_stretch_) +
                       " bad samples");
      bad_in_stretch_ = 0;
    }
    held_accel_mps2_ = accel;
  }
  if (!started_) {
    if (!have_theta_) {
      ++skipped_before_start_;
      return;
    }
    // The newest RL_THETA is this sample's; in an older log it may be ahead.
    Start(last_theta_, std::min(last_theta_.utime, msg.utime));
  }
  // Model time counts from the start: with epoch utimes (~1.7e9 s) a double
  // resolves only ~2e-7 s, and CVODE's root location would degrade with it.
  // (Subtracted in double: exact below 2^53 us, and no overflow on any utime.)
  const double t_s = (static_cast<double>(msg.utime) - static_cast<double>(start_utime_)) * 1e-6;
  if (config_.lookahead_samples == 0) {
    StepAll({t_s, accel, msg.utime, std::nan("")});
    return;
  }
  // Strictly after the held samples (a repeat returned above, a step back
  // reset and emptied the window): Push cannot refuse it.
  (void)window_.Push(t_s, accel);
  held_utime_.push_back(msg.utime);  // room: at most N are held between samples
  while (held_utime_.size() > static_cast<std::size_t>(config_.lookahead_samples)) StepOldestHeld();
}

void ModelNode::StepOldestHeld() {
  const std::int64_t utime = held_utime_.front();
  held_utime_.pop_front();
  StepAll({(static_cast<double>(utime) - static_cast<double>(start_utime_)) * 1e-6, 0.0, utime, window_.horizon_s()});
}

void ModelNode::FlushHeld() {
  if (!held_utime_.empty()) {
    window_.Close();
    while (!held_utime_.empty()) StepOldestHeld();
  }
  window_.Clear();
}

void ModelNode::StepAll(const Target& target) {
  if (workers_) {
    workers_->Run(target);
  } else {
    for (std::size_t i = 0; i < runners_.size(); ++i) StepRunner(i, target);
  }
  // Published from this thread, in configuration order, whoever stepped them.
  for (auto& vp : variants_) {
    Variant* v = vp.get();
    Runner& r = v->run;
    if (r.failed_now) {
      r.failed_now = false;
      ++failures_;
      Log()->error("{} stopped at utime {}: {}", r.label, target.utime, r.error);
      continue;
    }
    if (r.failed) continue;
    if (r.stack) {
      PublishStack(*v, target);
      continue;
    }
    const ModelState& st = r.model->state();
    v->msg.utime = target.utime;
    v->msg.theta = st.theta;
    v->msg.theta_dot = st.theta_dot;
    v->msg.chi = st.chi;
    v->msg.psi = st.psi;
    v->msg.energy = st.energy;
    v->msg.impact_count = st.impacts;
    v->msg.regime = RegimeCode(st.regime);
    v->msg.equations = EquationsCode(st.equations);
    bus_.Publish(v->channel, v->msg);
    ++v->msg.seq;
    ++published_;
    for (const ModelEvent& e : r.model->events()) {
      rocklab::event2_t ev;
      ev.utime = start_utime_ + static_cast<std::int64_t>(std::llround(e.time_s * 1e6));
      ev.seq = event_seq_++;
      ev.sender = sender_;
      ev.source = v->spec.name;
      ev.kind = EventCode(e.kind);
      ev.value = e.value;
      ev.detail = ToString(e.kind);
      bus_.Publish(event_channel_, ev);
    }
    r.model->ClearEvents();
  }
  for (auto& e : ensembles_) PublishBand(*e, target);
}

void ModelNode::PublishBand(Ensemble& e, const Target& target) {
  rocklab::model_band_t& b = e.msg;
  b.utime = target.utime;
  b.impacts_up = b.impacts_down = 0;
  b.impact_up_offset_sum = b.impact_up_offset_sq_sum = 0;
  b.impact_down_offset_sum = b.impact_down_offset_sq_sum = 0;
  e.thetas.clear();
  e.sigmas.clear();
  double sigma_sum = 0;
  for (std::size_t k = 0; k < e.members.size(); ++k) {
    Runner& m = e.members[k];
    if (m.failed_now) {
      m.failed_now = false;
      ++member_failures_;
      Log()->warn("{} stopped at utime {} and left the band: {}", m.label, target.utime, m.error);
      continue;
    }
    if (m.failed) continue;
    e.thetas.push_back(m.model->state().theta);
    e.sigmas.push_back(e.spec.draws[k].sigma);
    sigma_sum += e.spec.draws[k].sigma;
    // Impacts: theta crossing zero, the direction from theta_dot before it.
    for (const ModelEvent& ev : m.model->events()) {
      if (ev.kind != EventKind::kImpact || !(ev.value != 0)) continue;
      const double offset_s = ev.time_s - target.t_s;
      if (ev.value > 0) {
        ++b.impacts_up;
        b.impact_up_offset_sum += offset_s;
        b.impact_up_offset_sq_sum += offset_s * offset_s;
      } else {
        ++b.impacts_down;
        b.impact_down_offset_sum += offset_s;
        b.impact_down_offset_sq_sum += offset_s * offset_s;
      }
    }
    m.model->ClearEvents();
  }
  b.members = static_cast<std::int32_t>(e.thetas.size());
  b.noise_sigma = e.thetas.empty() ? 0.0 : sigma_sum / static_cast<double>(e.thetas.size());
  const BandQuantiles q = e.noisy ? ComputeNoisyBand(e.thetas, e.sigmas) : ComputeBand(e.thetas);
  b.theta_lo95 = q.lo95;
  b.theta_lo68 = q.lo68;
  b.theta_median = q.median;
  b.theta_hi68 = q.hi68;
  b.theta_hi95 = q.hi95;
  bus_.Publish(e.channel, b);
  ++b.seq;
  ++published_;
}

void ModelNode::InitStackVariant(Variant& v, const ModelOptions& options) {
  const VariantSpec& spec = v.spec;
  const stack::Stack& st = *spec.stack;
  const int n = st.bodies();
  const auto nn = static_cast<std::size_t>(n);
  stack::RunOptions ro;
  ro.rtol = options.rtol;
  ro.restitution = spec.restitution;
  // Adams, as simulate --assembly: with Dormand-Prince 5(4) the statue's
  // pedestal of README's step 9 overturned live at 1.2 s where Adams and
  // simulate on the same table record keep it below 0.007 rad
  // (docs/models.md, "In the model node").
  ro.integrator = Integrator::kAdams;
  v.run.stack = std::make_unique<stack::Stepper>(st, ro);
  rocklab::model_state4_t& m = v.bodies_msg;
  m.name = spec.name;
  m.model = ToString(spec.kind);
  m.nbodies = n;
  m.theta.assign(nn, 0.0);
  m.theta_dot.assign(nn, 0.0);
  m.chi.assign(nn, 0.0);
  m.psi.assign(nn, 0.0);
  m.regime.assign(nn, static_cast<std::int8_t>(rocklab::model_state4_t::REGIME_REST));  // a copy: no ODR use
  m.alpha.resize(nn);
  m.p.resize(nn);
  m.mu.resize(nn);
  for (int k = 0; k < n; ++k) {
    const BlockParams b = StackBodyParams(st, k, spec.restitution);
    m.alpha[static_cast<std::size_t>(k)] = b.alpha;
    m.p[static_cast<std::size_t>(k)] = b.p;
    m.mu[static_cast<std::size_t>(k)] = b.mu;
    const std::string below = k == 0 ? "table" : spec.body_names.at(static_cast<std::size_t>(k) - 1);
    v.interface_names.push_back(below + "/" + spec.body_names.at(static_cast<std::size_t>(k)));
  }
  m.l = 0.0;
  m.equations = rocklab::model_state4_t::EQUATIONS_HOUSNER;
  m.mode = stack::ModeName(stack::Mode{}, n);
  // E / (M g R) of the bottom body on its base corner.
  const stack::Body& b0 = st.body(0);
  v.stack_energy_scale_j = b0.mass_kg * kGravity * std::hypot(st.contact_half_width_m(0), b0.half_height_m);
}

void ModelNode::PublishStack(Variant& v, const Target& target) {
  Runner& r = v.run;
  const stack::Stepper& s = *r.stack;
  rocklab::model_state4_t& m = v.bodies_msg;
  const int n = m.nbodies;
  std::array<double, stack::kMaxBodies> theta{}, theta_dot{};
  s.BodyStates(theta.data(), theta_dot.data());
  const stack::Mode& mode = s.mode();
  bool moving = false;  // an interface at or below body k is open
  for (int k = 0; k < n; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    moving = moving || mode[kk] != 0;
    // The single block's sign, clockwise positive (0 - x: +0 at rest), as simulate --assembly's.
    m.theta[kk] = 0.0 - theta[kk];
    m.theta_dot[kk] = 0.0 - theta_dot[kk];
    m.chi[kk] = std::abs(m.theta[kk]) / m.alpha[kk];
    m.psi[kk] = m.theta[kk] >= 0.0 ? 0.0 : detail::kPi;
    m.regime[kk] = s.overturned() && k >= s.overturned_interface() ? rocklab::model_state4_t::REGIME_OVERTURNED
                   : moving ? rocklab::model_state4_t::REGIME_ROCKING
                            : rocklab::model_state4_t::REGIME_REST;
  }
  m.utime = target.utime;
  m.energy = s.EnergyAboveRest() / v.stack_energy_scale_j;
  m.impact_count = s.impacts();
  m.mode = stack::ModeName(mode, n);  // short: no allocation
  bus_.Publish(v.channel, m);
  ++m.seq;
  ++published_;
  for (const stack::Event& e : s.events()) {
    impacts_preload_ += e.rule == stack::Stack::ImpactRule::kPreload;
    impacts_held_pivots_ += e.rule == stack::Stack::ImpactRule::kHeldPivots;
    rocklab::event2_t ev;
    ev.utime = start_utime_ + static_cast<std::int64_t>(std::llround(e.time_s * 1e6));
    ev.seq = event_seq_++;
    ev.sender = sender_;
    ev.source = v.spec.name;
    ev.kind = EventCode(e.kind);
    ev.value = e.value;  // event_t's meaning per kind, of the interface (stack::Event::value)
    ev.detail = std::string(ToString(e.kind)) + " at interface " + std::to_string(e.interface) + " (" +
                v.interface_names[static_cast<std::size_t>(e.interface)] + "), mode " +
                stack::ModeName(e.after, n);
    // The model's assumptions (docs/models.md, "Impacts: the contact states after").
    if (e.rule == stack::Stack::ImpactRule::kPreload) ev.detail += ", resolved within the preloads";
    if (e.rule == stack::Stack::ImpactRule::kHeldPivots) ev.detail += ", resolved with pivots held";
    bus_.Publish(event_channel_, ev);
  }
  r.stack->ClearEvents();
}

void ModelNode::StepRunner(std::size_t i, const Target& target) {
  Runner& r = *runners_[i];
  if (r.failed) return;
  try {
    if (r.stack) {
      if (std::isnan(target.horizon_s)) {
        r.stack->Step(target.t_s, target.accel);
      } else {
        r.stack->AdvanceTo(target.t_s, window_, target.horizon_s);
      }
    } else if (std::isnan(target.horizon_s)) {
      r.model->Step(target.t_s, target.accel);
    } else {
      r.model->AdvanceAhead(target.t_s, window_, target.horizon_s);
    }
  } catch (const std::exception& e) {
    r.failed = true;
    r.failed_now = true;
    r.error = e.what();
  }
}

void ModelNode::PublishHealth(const char* state) {
  rocklab::health2_t h{};
  h.utime = last_table_utime_ == INT64_MIN ? 0 : last_table_utime_;
  h.seq = health_seq_++;
  h.sender = sender_;
  h.node = "model";
  h.state = state;
  h.count_in = table_count_;
  h.count_out = published_;
  // Dropped: table samples before the start and messages that did not decode.
  h.dropped = skipped_before_start_ + bus_.decode_error_count();
  h.bad_samples = failures_ + bad_table_samples_;
  // Messages missing on every stream (a frame lost on several counts on each).
  h.gaps = common::SeqGaps::SaturatingAdd(common::SeqGaps::SaturatingAdd(table_seq_.missing(), theta_seq_.missing()),
                                          bodies_seq_.missing());
  h.lag_s = std::nan("");  // sample clock and host clock are unrelated offline
  bus_.Publish(health_channel_, h);
}

void ModelNode::Run(const std::atomic<bool>& stop) {
  PublishHealth("running");
  common::RunNodeLoop(
      bus_, stop,
      [this] {
        const double now = HostNowS();
        if (now - last_health_host_s_ >= config_.health_period_s) {
          last_health_host_s_ = now;
          PublishHealth(started_ ? "running" : "waiting");
        }
      },
      2 * config_.subscriber_queue, "model_node");
  Finish();
}

void ModelNode::Finish() {
  FlushHeld();
  PublishHealth("stopped");
}

}  // namespace rocklab::model
