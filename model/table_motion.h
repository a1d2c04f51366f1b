#pragma once
/// @file
/// The table's displacement and acceleration at increasing times, from a
/// forcing: what the rig simulator (`rocklab synth`) turns into raw channel
/// values.

#include "model/excitation.h"

namespace rocklab::model {

/// Analytic excitations give the displacement exactly
/// (Forcing::ExactDisplacement); a sampled acceleration record (or a sum
/// holding one) is integrated twice by the trapezoidal rule from rest at
/// the first time asked: exact for a constant acceleration, with an error
/// of O(dt^2) for one linear between the times asked. Keeps `forcing` by
/// reference.
class TableMotion {
 public:
  explicit TableMotion(const Forcing& forcing) : forcing_(forcing) {}
  /// The motion at t_s (s), called with increasing times: displacement (m)
  /// and acceleration (m/s^2).
  void At(double t_s, double& displacement_m, double& acceleration_mps2);

 private:
  const Forcing& forcing_;
  bool started_{false};
  double t_{}, a_{}, v_{}, u_{};  // the previous time (s), u_g'' (m/s^2), u_g' (m/s), u_g (m)
};

}  // namespace rocklab::model
