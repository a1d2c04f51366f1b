#pragma once
/// @file
/// A model variant as the command line names it: `NAME:MODEL:PARAMS`, and
/// the parameter files `rocklab fit --out` writes.

#include <optional>
#include <string>

#include "model/block.h"
#include "model/rocking_model.h"

namespace rocklab::model {

/// One model variant to run: `NAME:MODEL:PARAMS` on the command line.
struct VariantSpec {
  std::string name;          ///< channel suffix: RL_MODEL_<name>; [A-Za-z0-9_]+
  ModelKind kind{};
  BlockParams params;
  std::string params_source; ///< "theoretical", "command line" or the JSON file
  ModelOptions options;
};

/// Parses `NAME:MODEL:PARAMS`, MODEL housner|complex, PARAMS `theoretical`
/// (then `theoretical` must hold the rig's geometric parameters),
/// `alpha=A,p=P,mu=M[,l=L][,handoff=K]` (rad, rad/s, 1, 1, 1; handoff: the
/// complex model's opt-in l -> 0 hand-off below K V_min, 0 = off, see
/// ModelOptions::complex_resolved_energy), or a JSON file with the keys
/// alpha, p, mu (and optionally l), as `rocklab fit --out` writes it.
/// @throws std::invalid_argument naming the variant and the part that is wrong.
VariantSpec ParseVariant(const std::string& text, const std::optional<BlockParams>& theoretical);

/// Reads alpha, p, mu (and l into `l` when present) from a JSON file.
/// @throws std::invalid_argument naming the file and key.
BlockParams ReadParamsJson(const std::string& path, double* l = nullptr);

}  // namespace rocklab::model
