#pragma once
/// @file
/// RL_MODEL_<name> read as a model_state2_t, whichever type carries it:
/// model_state3_t (what the model node publishes: its seq is dropped),
/// model_state2_t, or model_state_t (equations = EQUATIONS_UNKNOWN).
/// Superseded by common/versions.h (ModelStateDecoder reads all three as
/// model_state3_t, seq included); kept for code built against it.

#include <functional>
#include <string>

#include "common/bus.h"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::common {

/// Decodes either type into `out` (guarded: common::GuardedDecode).
/// `scratch` holds a model_state_t between calls (no allocation once its
/// strings have grown). nullptr on success, otherwise the reason.
const char* DecodeModelState(const void* data, int size, rocklab::model_state2_t& out,
                             rocklab::model_state_t& scratch);

/// The fields model_state_t has, copied into `out`; equations = EQUATIONS_UNKNOWN.
void ToModelState2(const rocklab::model_state_t& in, rocklab::model_state2_t& out);

/// Subscribes `handler` to the three types on `channel_regex`, with the typed
/// subscription's guard and counters (Bus::SubscribeDecoded).
Subscription SubscribeModelState(
    Bus& bus, const std::string& channel_regex,
    std::function<void(const std::string& channel, const rocklab::model_state2_t& msg)> handler,
    int queue_capacity = Bus::kDefaultQueue);

}  // namespace rocklab::common
