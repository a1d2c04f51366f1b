#include "model/model_node.h"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "common/node_support.h"
#include "rocklab/event_t.hpp"
#include "rocklab/health_t.hpp"

namespace rocklab::model {
namespace {

using common::HostNowS;

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> log = common::NamedLogger("model_node");
  return log;
}

double ParseNumber(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v)) {
    throw std::invalid_argument(what + ": '" + text + "' is not a number");
  }
  return v;
}

std::int8_t RegimeCode(Regime r) {
  switch (r) {
    case Regime::kRest: return rocklab::model_state_t::REGIME_REST;
    case Regime::kRocking: return rocklab::model_state_t::REGIME_ROCKING;
    case Regime::kOverturned: return rocklab::model_state_t::REGIME_OVERTURNED;
  }
  return rocklab::model_state_t::REGIME_REST;
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

}  // namespace

BlockParams ReadParamsJson(const std::string& path, double* l) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read parameter file '" + path + "'");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(path + ": not JSON: " + e.what());
  }
  auto get = [&](const char* key) {
    if (!j.is_object() || !j.contains(key) || !j.at(key).is_number()) {
      throw std::invalid_argument(path + ": key '" + key + "' missing or not a number");
    }
    return j.at(key).get<double>();
  };
  BlockParams p{get("alpha"), get("p"), get("mu")};
  if (l && j.is_object() && j.contains("l") && j.at("l").is_number()) *l = j.at("l").get<double>();
  try {
    p.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
  return p;
}

VariantSpec ParseVariant(const std::string& text, const std::optional<BlockParams>& theoretical) {
  const std::string where = "variant '" + text + "'";
  const std::size_t c1 = text.find(':');
  const std::size_t c2 = c1 == std::string::npos ? c1 : text.find(':', c1 + 1);
  if (c2 == std::string::npos) {
    throw std::invalid_argument(where + ": expected NAME:MODEL:PARAMS");
  }
  VariantSpec v;
  v.name = text.substr(0, c1);
  if (v.name.empty()) throw std::invalid_argument(where + ": empty NAME");
  for (char ch : v.name) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_') {
      throw std::invalid_argument(where + ": NAME may hold only letters, digits and _");
    }
  }
  try {
    v.kind = ParseModelKind(text.substr(c1 + 1, c2 - c1 - 1));
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument(where + ": MODEL must be housner or complex");
  }
  const std::string params = text.substr(c2 + 1);
  if (params == "theoretical") {
    if (!theoretical) {
      throw std::invalid_argument(where + ": 'theoretical' needs the block geometry in the rig file");
    }
    v.params = *theoretical;
    v.params_source = "theoretical";
  } else if (params.find('=') != std::string::npos) {
    bool has_alpha = false, has_p = false, has_mu = false;
    std::size_t start = 0;
    while (start <= params.size()) {
      const std::size_t comma = std::min(params.find(',', start), params.size());
      const std::string item = params.substr(start, comma - start);
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos) throw std::invalid_argument(where + ": '" + item + "' is not KEY=VALUE");
      const std::string key = item.substr(0, eq);
      const double value = ParseNumber(item.substr(eq + 1), where + ": " + key);
      if (key == "alpha") {
        v.params.alpha = value;
        has_alpha = true;
      } else if (key == "p") {
        v.params.p = value;
        has_p = true;
      } else if (key == "mu") {
        v.params.mu = value;
        has_mu = true;
      } else if (key == "l") {
        v.options.l = value;
      } else if (key == "handoff") {  // opt-in l -> 0 hand-off of the complex model
        v.options.complex_resolved_energy = value;
      } else {
        throw std::invalid_argument(where + ": unknown key '" + key + "' (expected alpha, p, mu, l, handoff)");
      }
      start = comma + 1;
    }
    if (!has_alpha || !has_p || !has_mu) {
      throw std::invalid_argument(where + ": needs alpha, p and mu");
    }
    v.params_source = "command line";
  } else {
    v.params = ReadParamsJson(params, &v.options.l);
    v.params_source = params;
  }
  try {
    v.params.Validate();
    v.options.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(where + ": " + e.what());
  }
  return v;
}

void ModelNodeConfig::Validate() const {
  if (variants.empty()) throw std::invalid_argument("model node: no variant configured");
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
}

struct ModelNode::Variant {
  VariantSpec spec;
  std::unique_ptr<RockingModel> model;
  std::string channel;
  rocklab::model_state_t msg{};
  bool failed{};
};

ModelNode::ModelNode(const ModelNodeConfig& config, lcm::LCM* publisher)
    : config_(config), publisher_(publisher), theta_history_(kThetaHistory) {
  config_.Validate();
  for (const VariantSpec& spec : config_.variants) {
    auto v = std::make_unique<Variant>();
    v->spec = spec;
    v->model = RockingModel::Create(spec.kind, spec.params, spec.options);
    v->channel = config_.channel_prefix + "MODEL_" + spec.name;
    v->msg.name = spec.name;
    v->msg.model = ToString(spec.kind);
    v->msg.alpha = spec.params.alpha;
    v->msg.p = spec.params.p;
    v->msg.mu = spec.params.mu;
    v->msg.l = spec.kind == ModelKind::kComplex ? spec.options.l : 0.0;
    variants_.push_back(std::move(v));
  }
  last_health_host_s_ = HostNowS();
}

ModelNode::~ModelNode() = default;

std::size_t ModelNode::variant_count() const { return variants_.size(); }

const rocklab::model_state_t& ModelNode::latest(std::size_t i) const { return variants_.at(i)->msg; }

void ModelNode::Start(const rocklab::block_state_t& theta) {
  const bool at_rest = !std::isfinite(theta.theta) || std::abs(theta.theta) < config_.rest_threshold_rad;
  const double theta0 = at_rest ? 0.0 : theta.theta;
  const double theta_dot0 = at_rest || !std::isfinite(theta.theta_dot) ? 0.0 : theta.theta_dot;
  for (auto& v : variants_) {
    try {
      v->model->Reset(0.0, theta0, theta_dot0);
      v->model->ClearEvents();
      v->failed = false;
    } catch (const std::exception& e) {
      v->failed = true;
      ++failures_;
      Log()->error("variant '{}': reset failed: {}", v->spec.name, e.what());
    }
  }
  started_ = true;
  start_utime_ = theta.utime;
  Log()->info("variants start at utime {} from theta {:.5f} rad{}", theta.utime, theta0,
              at_rest ? " (at rest)" : "");
}

void ModelNode::HandleTheta(const rocklab::block_state_t& msg) {
  // Time going back starts a new run: the old thetas cannot start it.
  if (theta_count_ > 0 && msg.utime < ThetaAt(theta_count_ - 1).utime) theta_count_ = 0;
  theta_history_[theta_count_ % theta_history_.size()] = msg;  // plain data: no allocation
  ++theta_count_;
}

const rocklab::block_state_t& ModelNode::ThetaAt(std::size_t i) const {
  return theta_history_[i % theta_history_.size()];
}

const rocklab::block_state_t* ModelNode::StartTheta(std::int64_t table_utime) const {
  // The DAQ delays RL_TABLE more than RL_THETA (its differentiators' half
  // windows), so the theta of this table sample is usually behind the newest.
  const std::size_t kept = std::min(theta_count_, theta_history_.size());
  for (std::size_t back = 1; back <= kept; ++back) {
    const rocklab::block_state_t& t = ThetaAt(theta_count_ - back);
    if (t.utime <= table_utime) return &t;
  }
  return nullptr;
}

void ModelNode::HandleTable(const rocklab::table_state_t& msg) {
  if (last_table_utime_ != INT64_MIN && msg.utime <= last_table_utime_) {
    if (msg.utime == last_table_utime_) return;  // duplicate: the DAQ already counted it
    ++resets_;
    started_ = false;
    Log()->info("table time went back from {} to {} us: reset", last_table_utime_, msg.utime);
  }
  last_table_utime_ = msg.utime;
  ++table_count_;
  if (!started_) {
    // Start from the newest RL_THETA that is not ahead of this table sample.
    const rocklab::block_state_t* theta = StartTheta(msg.utime);
    if (!theta) {
      ++skipped_before_start_;
      return;
    }
    Start(*theta);
  }
  // Model time counts from the start: with epoch utimes (~1.7e9 s) a double
  // resolves only ~2e-7 s, and CVODE's root location would degrade with it.
  const double t_s = static_cast<double>(msg.utime - start_utime_) * 1e-6;
  for (auto& v : variants_) {
    if (v->failed) continue;
    try {
      v->model->Step(t_s, msg.acceleration);
    } catch (const std::exception& e) {
      v->failed = true;
      ++failures_;
      Log()->error("variant '{}' stopped at utime {}: {}", v->spec.name, msg.utime, e.what());
      continue;
    }
    const ModelState& st = v->model->state();
    v->msg.utime = msg.utime;
    v->msg.theta = st.theta;
    v->msg.theta_dot = st.theta_dot;
    v->msg.chi = st.chi;
    v->msg.psi = st.psi;
    v->msg.energy = st.energy;
    v->msg.impact_count = st.impacts;
    v->msg.regime = RegimeCode(st.regime);
    if (publisher_) {
      publisher_->publish(v->channel, &v->msg);
      ++published_;
      for (const ModelEvent& e : v->model->events()) {
        rocklab::event_t ev;
        ev.utime = start_utime_ + static_cast<std::int64_t>(std::llround(e.time_s * 1e6));
        ev.source = v->spec.name;
        ev.kind = EventCode(e.kind);
        ev.value = e.value;
        ev.detail = ToString(e.kind);
        publisher_->publish(config_.channel_prefix + "EVENT", &ev);
      }
    }
    v->model->ClearEvents();
    if (config_.on_state) {
      try {
        config_.on_state(v->msg);
      } catch (const std::exception& e) {
        ++failures_;
        Log()->error("variant '{}': on_state observer: {}", v->spec.name, e.what());
      }
    }
  }
}

void ModelNode::PublishHealth(const char* state) {
  if (!publisher_) return;
  rocklab::health_t h{};
  h.utime = last_table_utime_ == INT64_MIN ? 0 : last_table_utime_;
  h.node = "model";
  h.state = state;
  h.count_in = table_count_;
  h.count_out = published_;
  h.dropped = skipped_before_start_;
  h.bad_samples = failures_;
  h.lag_s = std::nan("");  // sample clock and host clock are unrelated offline
  publisher_->publish(config_.channel_prefix + "HEALTH", &h);
}

void ModelNode::OnTable(const lcm::ReceiveBuffer*, const std::string&,
                        const rocklab::table_state_t* msg) {
  try {
    HandleTable(*msg);
  } catch (const std::exception& e) {
    Log()->error("RL_TABLE handler: {}", e.what());
  }
}

void ModelNode::OnTheta(const lcm::ReceiveBuffer*, const std::string&,
                        const rocklab::block_state_t* msg) {
  try {
    HandleTheta(*msg);
  } catch (const std::exception& e) {
    Log()->error("RL_THETA handler: {}", e.what());
  }
}

void ModelNode::Run(lcm::LCM& subscriber, const std::atomic<bool>& stop) {
  lcm::Subscription* table =
      subscriber.subscribe(config_.channel_prefix + "TABLE", &ModelNode::OnTable, this);
  lcm::Subscription* theta =
      subscriber.subscribe(config_.channel_prefix + "THETA", &ModelNode::OnTheta, this);
  table->setQueueCapacity(config_.subscriber_queue);
  theta->setQueueCapacity(config_.subscriber_queue);
  PublishHealth("running");
  while (!stop.load()) {
    if (subscriber.handleTimeout(100) < 0) {
      if (!stop.load()) Log()->error("LCM handleTimeout failed");  // a stop signal interrupts it
      break;
    }
    const double now = HostNowS();
    if (now - last_health_host_s_ >= config_.health_period_s) {
      last_health_host_s_ = now;
      PublishHealth(started_ ? "running" : "waiting");
    }
  }
  // What arrived before the stop is still handled (bounded: the queues' size).
  common::DispatchQueued(subscriber, 2 * config_.subscriber_queue);
  subscriber.unsubscribe(table);
  subscriber.unsubscribe(theta);
  Finish();
}

void ModelNode::Finish() { PublishHealth("stopped"); }

}  // namespace rocklab::model
