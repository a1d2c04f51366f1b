#pragma once
// What the rocking-model tests share: Table 2's blocks and a constant table
// acceleration.

#include "model/block.h"
#include "model/excitation.h"
#include "tests/paper_blocks.h"

namespace rocklab::model::fixtures {

using ::rocklab::test::kBlock1;  // Table 2, block 1 (tests/paper_blocks.h)
using ::rocklab::test::kBlock2;  // Table 2, block 2

/// u_g'' = a for all t, m/s^2.
class ConstantForcing final : public Forcing {
 public:
  explicit ConstantForcing(double a) : a_(a) {}
  double TableAcceleration(double) const override { return a_; }

 private:
  double a_;
};

}  // namespace rocklab::model::fixtures
