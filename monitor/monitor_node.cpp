#include "monitor/monitor_node.h"

#include <stdexcept>

#include "common/node_support.h"

namespace rocklab::monitor {

void MonitorNodeConfig::Validate() const {
  server.Validate();
  if (queue_capacity < 1) throw std::invalid_argument("monitor option queue_capacity out of range");
}

MonitorNode::MonitorNode(const MonitorNodeConfig& config, common::Bus& bus)
    : config_(config), bus_(bus), state_(config.live) {
  config_.Validate();
  server_ = std::make_unique<MonitorServer>(state_, config_.server);
  subscription_ = bus_.SubscribeRaw(
      config_.live.channel_prefix + ".*",
      [this](const std::string& channel, const void* data, int size) {
        state_.Ingest(channel, data, size);  // decodes and counts; never throws
      },
      config_.queue_capacity);
}

MonitorNode::~MonitorNode() { subscription_.Reset(); }

std::string MonitorNode::url() const { return server_->url(); }

void MonitorNode::Start() {
  if (started_) return;
  server_->Start();
  started_ = true;
}

bool MonitorNode::Run(const std::atomic<bool>& stop) {
  Start();
  const bool ok = common::RunNodeLoop(bus_, stop, {}, config_.queue_capacity, "monitor");
  server_->Stop();
  return ok;
}

}  // namespace rocklab::monitor
