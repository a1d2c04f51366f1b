#pragma once
/// @file
/// RL_MODEL_<name> carries model_state2_t (the model node since it says which
/// equations produced each sample) or model_state_t (logs written before).
/// Consumers accept both, told apart by the fingerprint; a model_state_t is
/// read as a model_state2_t with equations = EQUATIONS_UNKNOWN.
/// Superseded by common/versions.h (model_state3_t, with seq, and the other
/// types' successors); kept for code built against it.

#include <functional>
#include <string>

#include "common/bus.h"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::common {

/// Decodes either type into `out` (guarded: common::GuardedDecode).
/// `scratch` holds a model_state_t between calls (no allocation once its
/// strings have grown). nullptr on success, otherwise the reason.
const char* DecodeModelState(const void* data, int size, rocklab::model_state2_t& out,
                             rocklab::model_state_t& scratch);

/// The fields model_state_t has, copied into `out`; equations = EQUATIONS_UNKNOWN.
void ToModelState2(const rocklab::model_state_t& in, rocklab::model_state2_t& out);

/// Subscribes `handler` to both types on `channel_regex`, with the typed
/// subscription's guard and counters (Bus::SubscribeDecoded).
Subscription SubscribeModelState(
    Bus& bus, const std::string& channel_regex,
    std::function<void(const std::string& channel, const rocklab::model_state2_t& msg)> handler,
    int queue_capacity = Bus::kDefaultQueue);

}  // namespace rocklab::common
