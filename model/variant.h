#pragma once
/// @file
/// A model variant as the command line names it: `NAME:MODEL:PARAMS`, and
/// the parameter files `rocklab fit --out` writes.

#include <optional>
#include <string>
#include <vector>

#include "model/block.h"
#include "model/rocking_model.h"
#include "model/stack.h"

namespace rocklab::model {

/// One model variant to run: `NAME:MODEL:PARAMS` on the command line.
struct VariantSpec {
  std::string name;          ///< channel suffix: RL_MODEL_<name>; [A-Za-z0-9_]+
  ModelKind kind{};
  BlockParams params;
  std::string params_source; ///< "theoretical", "command line", the JSON file or the assembly file
  ModelOptions options;
  /// PARAMS an assembly file (`*.toml`, docs/models.md "The model node"),
  /// read by pipeline::BuildVariants: a one-body assembly or a frame sets
  /// `params` (its single block); a stack of two or more bodies sets
  /// `stack`, its interfaces' restitution and its bodies' names, and
  /// `params` to the stack's single-block summary (pipeline::StackRowParams).
  std::string assembly_path;
  std::optional<stack::Stack> stack;
  std::vector<double> restitution;  ///< per interface bottom-up, < 0: the angular momentum rule
  std::vector<std::string> body_names;
};

/// Parses `NAME:MODEL:PARAMS`, MODEL housner|complex, PARAMS a file
/// ending in `.toml` (an assembly: only its path is kept, in
/// assembly_path, for the caller to read), `theoretical`
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
