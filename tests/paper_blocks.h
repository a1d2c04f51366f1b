#pragma once
/// @file
/// The paper's Table 2, shared by the tests that use it: the fitted
/// parameters of blocks 1 and 2 (alpha in rad, p in 1/s, mu). One
/// definition, so test files compiled in one unity batch do not clash.

#include "model/block.h"

namespace rocklab::test {

inline constexpr model::BlockParams kBlock1{0.235, 3.884, 0.937};
inline constexpr model::BlockParams kBlock2{0.168, 3.767, 0.942};

}  // namespace rocklab::test
