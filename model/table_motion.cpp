#include "model/table_motion.h"

#include <optional>

namespace rocklab::model {

void TableMotion::At(double t, double& displacement, double& acceleration) {
  acceleration = forcing_.TableAcceleration(t);
  if (const std::optional<double> exact = forcing_.ExactDisplacement(t)) {
    displacement = *exact;
    return;
  }
  if (started_) {
    const double dt = t - t_;
    const double v = v_ + 0.5 * (a_ + acceleration) * dt;
    u_ += 0.5 * (v_ + v) * dt;
    v_ = v;
  }
  started_ = true;
  t_ = t;
  a_ = acceleration;
  displacement = u_;
}

}  // namespace rocklab::model
