#pragma once
/// @file
/// The posterior ensemble's command-line flags, shared by `rocklab model`
/// and `rocklab run`: K draws of a posterior samples CSV run beside the
/// point variants (RL_BAND_<name>; docs/commands.md, "Posterior band").

#include <cstdio>
#include <string>
#include <vector>

#include "model/ensemble.h"

namespace CLI {
class App;
}

namespace rocklab::pipeline {

struct EnsembleFlags {
  std::string samples_path;       ///< --posterior-samples; empty: no ensemble
  int size{32};                   ///< --ensemble: draws K
  std::string model{"complex"};   ///< --ensemble-model: housner | complex
  std::string name{"posterior"};  ///< --ensemble-name: RL_BAND_<name>
};

/// Adds --posterior-samples --ensemble --ensemble-model --ensemble-name to
/// `cmd`, storing into `flags` (which must outlive parsing).
void AddEnsembleOptions(CLI::App& cmd, EnsembleFlags& flags);

/// The ensemble the flags ask for (none without --posterior-samples), its
/// members' relative tolerance `rtol`.
/// @throws OptionError naming the option (a bad file: FILE:LINE, column).
std::vector<model::EnsembleSpec> BuildEnsembles(const EnsembleFlags& flags, double rtol);

/// One line per ensemble on `out` (its model, draws, file, and when the file
/// had fewer rows than `asked`, that all were taken).
void PrintEnsembles(const std::vector<model::EnsembleSpec>& ensembles, int asked, std::FILE* out);

}  // namespace rocklab::pipeline
