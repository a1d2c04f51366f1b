#pragma once
/// @file
/// Paths into the source tree that many tests use (ROCKLAB_SOURCE_DIR is
/// defined for every test executable). One definition, so test files
/// compiled in one unity batch do not clash.

#include <string>

namespace rocklab::test {

inline const std::string kSource = ROCKLAB_SOURCE_DIR;
inline const std::string kLabRig = kSource + "/data/rigs/lab_rig.toml";

}  // namespace rocklab::test
