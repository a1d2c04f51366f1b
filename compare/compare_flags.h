#pragma once
/// @file
/// The comparator's command-line flags, shared by `rocklab compare` and
/// `rocklab run`. Their values are checked by
/// pipeline::ValidateCompareOptions.

#include "compare/compare_node.h"

namespace CLI {
class App;
}

namespace rocklab::compare {

/// Adds --compare-rate --window --stale --stale-clock to `cmd`, storing
/// into `config` (which must outlive parsing).
void AddCompareOptions(CLI::App& cmd, CompareNodeConfig& config);

}  // namespace rocklab::compare
