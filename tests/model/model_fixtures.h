#pragma once
// What the rocking-model tests share: Table 2's blocks and a constant table
// acceleration.

#include "model/block.h"
#include "model/excitation.h"

namespace rocklab::model::fixtures {

inline const BlockParams kBlock1{0.235, 3.884, 0.937};  // Table 2, block 1
inline const BlockParams kBlock2{0.168, 3.767, 0.942};  // Table 2, block 2

/// u_g'' = a for all t, m/s^2.
class ConstantForcing final : public Forcing {
 public:
  explicit ConstantForcing(double a) : a_(a) {}
  double TableAcceleration(double) const override { return a_; }

 private:
  double a_;
};

}  // namespace rocklab::model::fixtures
