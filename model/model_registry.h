#pragma once
/// @file
/// The registry of rocking models: what every command, node and binding
/// needs to know of a model, by its kind or its name, in one table
/// (model_registry.cpp). Adding a model means adding its entry there (and
/// its ModelKind, the public name the libraries and Python take): the
/// factory, the names in messages and the choices that used to be switches
/// over ModelKind in each caller are read from the entry.

#include <memory>
#include <string>
#include <vector>

#include "model/rocking_model.h"

namespace rocklab::model {

/// One registered model.
struct ModelInfo {
  ModelKind kind{};
  /// Its name on the command line, in files and in messages ("housner").
  const char* name{};
  /// A single block of these parameters (already validated by the caller).
  std::unique_ptr<RockingModel> (*make)(const BlockParams& params, const ModelOptions& options){};
  /// How a whole record is stepped (simulate, sweep, an assembly's single
  /// block): the integrator that costs least at the default tolerance.
  Integrator batch_integrator{Integrator::kAdams};
  /// Its messages carry ModelOptions::l (model_state*_t.l; else 0).
  bool has_l{};
  /// Most rigid bodies it runs as one assembly: 1 for a single block only,
  /// more for the Housner-type stack of blocks (model/stack.h).
  int max_bodies{1};
};

/// Every registered model, in the order messages list them.
const std::vector<ModelInfo>& Models();
/// The entry of `kind`. @throws std::invalid_argument for a kind not registered.
const ModelInfo& FindModel(ModelKind kind);
/// The entry named `name`, or nullptr.
const ModelInfo* FindModel(const std::string& name);
/// The registered names joined by `separator` ("housner, complex").
std::string ModelNames(const char* separator);

}  // namespace rocklab::model
