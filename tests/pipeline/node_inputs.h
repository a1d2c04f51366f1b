#pragma once
// Inputs of the model and compare node tests (node_queue_test.cpp over udpm,
// node_memq_test.cpp over memq): one Housner variant and 1 kHz samples.

#include <cstdint>

#include "model/model_node.h"

namespace rocklab::test {

/// Sample k of a 1 kHz stream: utime and seq set, the rest zero.
template <class Msg>
Msg Sample(int k) {
  Msg msg{};
  msg.utime = 1000 * static_cast<std::int64_t>(k);
  msg.seq = k;
  return msg;
}

/// One Housner variant "h" of the lab block (alpha rad, p rad/s, mu).
inline model::ModelNodeConfig OneHousnerVariant() {
  model::ModelNodeConfig config;
  model::VariantSpec v;
  v.name = "h";
  v.kind = model::ModelKind::kHousner;
  v.params = {0.245, 3.78, 0.91};
  config.variants = {v};
  return config;
}

}  // namespace rocklab::test
