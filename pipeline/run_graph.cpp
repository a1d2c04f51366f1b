#include "pipeline/run_graph.h"

#include <exception>
#include <stdexcept>

#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"

namespace rocklab::pipeline {
namespace {

bool IsMemq(const std::string& url) { return url.rfind("memq://", 0) == 0; }

}  // namespace

RunGraph::RunGraph(const RunGraphConfig& c) {
  if (!IsMemq(c.lcm_url)) {
    net_ = OpenLcmBus(c.lcm_url);
    forward_ = direct_.SubscribeRaw(".*", [this](const std::string& channel, const void* data, int size) {
      if (!net_->Publish(channel, data, size)) ++forward_errors_;
    });
  }
  if (!c.log_path.empty()) {
    try {
      log_ = std::make_unique<common::LogWriter>(c.log_path);
    } catch (const std::runtime_error&) {
      throw OptionError("--log: cannot write '" + c.log_path + "'");
    }
    logged_ = std::make_unique<common::LogWritingBus>(direct_, *log_);
  }
  bus_ = logged_ ? static_cast<common::Bus*>(logged_.get()) : &direct_;

  // Subscription order is dispatch order (file comment): comparator first.
  compare_ = std::make_unique<compare::CompareNode>(c.compare, *bus_);
  model_ = std::make_unique<model::ModelNode>(c.model, *bus_);
  try {
    daq_ = std::make_unique<daq::DaqNode>(c.daq, *bus_);
  } catch (const std::exception& e) {
    throw OptionError(std::string("--input: ") + e.what());
  }
}

RunGraph::~RunGraph() = default;

void RunGraph::Run(const std::atomic<bool>& stop) {
  daq_->Run(stop);
  model_->Finish();
  compare_->Finish();
  if (log_) log_->Close();
}

}  // namespace rocklab::pipeline
