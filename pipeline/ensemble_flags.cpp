#include "pipeline/ensemble_flags.h"

#include <stdexcept>

#include <CLI/CLI.hpp>

#include "model/model_registry.h"
#include "pipeline/option_error.h"

namespace rocklab::pipeline {

void AddEnsembleOptions(CLI::App& cmd, EnsembleFlags& f) {
  cmd.add_option("--posterior-samples", f.samples_path,
                 "posterior draws CSV (columns alpha, p, mu [, l], ...; `fit --posterior --samples`): "
                 "run an ensemble of them beside the variants, published as RL_BAND_<name>");
  cmd.add_option("--ensemble", f.size, "draws K in the ensemble, evenly spaced rows of the file")
      ->capture_default_str();
  cmd.add_option("--ensemble-model", f.model, "the ensemble's model: housner | complex")
      ->capture_default_str();
  cmd.add_option("--ensemble-name", f.name, "the ensemble's name (channel RL_BAND_<name>)")
      ->capture_default_str();
}

std::vector<model::EnsembleSpec> BuildEnsembles(const EnsembleFlags& f, double rtol) {
  if (f.samples_path.empty()) return {};
  if (f.size < 1) throw OptionError("--ensemble: must be >= 1, got " + std::to_string(f.size));
  model::ModelKind kind{};
  try {
    kind = model::ParseModelKind(f.model);
  } catch (const std::invalid_argument&) {
    throw OptionError("--ensemble-model: '" + f.model + "' is not " + model::ModelNames(" or "));
  }
  model::ModelOptions options;
  options.rtol = rtol;
  try {
    return {model::MakeEnsemble(f.name, kind, f.samples_path, f.size, options)};
  } catch (const std::invalid_argument& e) {
    throw OptionError(std::string("--posterior-samples: ") + e.what());
  }
}

}  // namespace rocklab::pipeline

namespace rocklab::pipeline {

void PrintEnsembles(const std::vector<model::EnsembleSpec>& ensembles, int asked, std::FILE* out) {
  for (const model::EnsembleSpec& e : ensembles) {
    std::fprintf(out, "ensemble %s: %s, %zu draws of %s%s\n", e.name.c_str(), model::ToString(e.kind),
                 e.draws.size(), e.source.c_str(),
                 static_cast<int>(e.draws.size()) < asked ? " (every row: the file has fewer than --ensemble)"
                                                          : " (evenly spaced rows)");
  }
}

}  // namespace rocklab::pipeline
