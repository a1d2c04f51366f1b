#pragma once
// What the model-node tests feed the node: an RL_TABLE and an RL_THETA
// message with only the fields the node reads set.

#include <cstdint>

#include "rocklab/block_state_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::model::node_messages {

/// RL_TABLE of sample clock `utime` (us) with table acceleration `accel` (m/s^2).
inline rocklab::table_state_t Table(std::int64_t utime, double accel) {
  rocklab::table_state_t m{};
  m.utime = utime;
  m.acceleration = accel;
  return m;
}

/// RL_THETA of sample clock `utime` (us) with rocking angle `theta` (rad).
inline rocklab::block_state_t Theta(std::int64_t utime, double theta) {
  rocklab::block_state_t m{};
  m.utime = utime;
  m.theta = theta;
  return m;
}

}  // namespace rocklab::model::node_messages
