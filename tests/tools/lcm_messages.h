#pragma once
// Small rocklab messages for tests, the fields a test does not set left zero.

#include <cstdint>
#include <string>

#include "rocklab/block_state_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::test {

/// RL_THETA at `utime` (us): theta (rad) and the FLAG_ bits.
inline rocklab::block_state_t Theta(std::int64_t utime, double theta, std::int32_t flags = 0) {
  rocklab::block_state_t m{};
  m.utime = utime;
  m.theta = theta;
  m.flags = flags;
  return m;
}

/// RL_MODEL_<name> at `utime` (us): a Housner variant with Table 2's block 1
/// parameters (alpha 0.235 rad, p 3.884 rad/s, mu 0.937) at theta (rad), in
/// either model state type (model_state_t or model_state3_t).
template <class ModelMsg>
ModelMsg HousnerModelState(const std::string& name, std::int64_t utime, double theta) {
  ModelMsg m{};
  m.utime = utime;
  m.name = name;
  m.model = "housner";
  m.theta = theta;
  m.alpha = 0.235;
  m.p = 3.884;
  m.mu = 0.937;
  return m;
}

/// As the model node publishes it (model_state3_t, Housner's equations).
inline rocklab::model_state3_t Model(const std::string& name, std::int64_t utime, double theta) {
  auto m = HousnerModelState<rocklab::model_state3_t>(name, utime, theta);
  m.equations = rocklab::model_state3_t::EQUATIONS_HOUSNER;
  return m;
}

/// The same as an older log carries it (model_state_t, no equations field).
inline rocklab::model_state_t OldModel(const std::string& name, std::int64_t utime, double theta) {
  return HousnerModelState<rocklab::model_state_t>(name, utime, theta);
}

}  // namespace rocklab::test
