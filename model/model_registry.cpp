#include "model/model_registry.h"

#include <stdexcept>

#include "model/rocking_impl.h"
#include "model/stack.h"

namespace rocklab::model {

const std::vector<ModelInfo>& Models() {
  // Housner's smooth flights between impacts: Dormand-Prince 8(5,3) takes a
  // fifth of Adams' right-hand sides at the same tolerance, without CVODE's
  // per-step bookkeeping (docs/performance.md, "Issue 33"). Eq. (10) keeps
  // Adams. Only Housner's equations are derived for a stack of several
  // bodies (docs/models.md, "Assemblies").
  static const std::vector<ModelInfo> registered = {
      {ModelKind::kHousner, "housner", &detail::MakeHousner, Integrator::kDormandPrince853, false,
       stack::kMaxBodies},
      {ModelKind::kComplex, "complex", &detail::MakeComplex, Integrator::kAdams, true, 1},
  };
  return registered;
}

const ModelInfo& FindModel(ModelKind kind) {
  for (const ModelInfo& m : Models()) {
    if (m.kind == kind) return m;
  }
  throw std::invalid_argument("model kind " + std::to_string(static_cast<int>(kind)) + " is not registered");
}

const ModelInfo* FindModel(const std::string& name) {
  for (const ModelInfo& m : Models()) {
    if (name == m.name) return &m;
  }
  return nullptr;
}

std::string ModelNames(const char* separator) {
  std::string out;
  for (const ModelInfo& m : Models()) {
    if (!out.empty()) out += separator;
    out += m.name;
  }
  return out;
}

}  // namespace rocklab::model
