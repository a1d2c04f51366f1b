// The paper's complex formulation (eq. 10 with ERRATA items 3-5). In
// normalised time t = p tau:
//   chi_ddot = l^2/chi^3 - sin(alpha - alpha chi)/alpha
//              + (2 ln(mu)/pi) l chi_dot/chi^2
//              + a/(g alpha) cos(alpha - alpha chi) cos(psi),   a = -u_g''
//   psi_dot  = l/chi^2
// theta = alpha chi cos(psi). An impact is psi crossing pi/2 + k pi.
//
// Coordinates. psi_dot = l/chi^2 says chi^2 psi_dot = l is conserved, and
// l^2/chi^3 = chi psi_dot^2 is the centrifugal term of a particle in the
// plane: eq. (10) is exactly the planar motion of a particle at
// (x, y) = chi (cos psi, sin psi) under the purely radial force
//   F_r = -sin(alpha - alpha chi)/alpha + (2 ln(mu)/pi) l chi_dot/chi^2
//         + a/(g alpha) cos(alpha - alpha chi) x/chi,
//   (x, y)'' = F_r (x, y)/chi,   chi_dot = (x x' + y y')/chi,
// whose angular momentum x y' - y x' is l. The model integrates this form,
// state (x, y, dx/dtau, dy/dtau) in physical time, theta = alpha x,
// theta_dot = alpha dx/dtau; an impact is x crossing 0. It is eq. (10), not
// an approximation of it: only the coordinates differ. With l small a
// crossing passes the origin at the distance b = l / v (v the normalised
// speed) within a time b / v. In (chi, psi) the solution turns psi by pi and
// bends chi round a hyperbola there, and l^2/chi^3 is singular; in (x, y) the
// path is a straight line, bent only by the damping term, and every term of
// F_r is bounded except the damping term ~ v^2 / b. Measured, though
// (rocklab_complex_convergence, last table), CVODE crosses as cheaply and as
// accurately in (chi, psi) at the same tolerances (one impact of free
// rocking: 1973 against 2121 steps, energy ratio 1.8e-7 against 2.1e-7 from
// its limit at l = 1e-10): what made the old model fail was the hand-off
// and the start from rest (below), not the coordinates. Exactly in the limit
// l -> 0 (Binet's equation u'' - (2 ln mu / pi) u' + u = 0 for u = 1/chi(psi)
// near the origin) a crossing multiplies the energy by mu^(2/w),
// w = sqrt(1 - (ln mu / pi)^2), and turns the path by pi / w, not pi: the
// line of the motion precesses by pi (1/w - 1) per crossing (6.7e-4 rad for
// mu = 0.937), a property of eq. (10) that Housner's model does not have.
//
// Start from rest (ERRATA item 6). eq. (10) has no state of rest: a state
// with zero velocity has no angular momentum. Its state of least energy is
// the circular orbit chi = chi_m = (l^2 alpha / sin alpha)^(1/3) (V_min ~
// 1.5 chi_m), which is not a start: near chi_m gravity and l^2/chi^3
// dominate a table acceleration just above g tan(alpha), the block circles
// and leaves on a ray turned by O(1) from psi = 0 whatever l is (measured on
// figure 8's first uplift: from the orbit at psi = 0, 0.82 rad at l = 1e-6;
// from the orbit where it crosses x = 0, 0.10 .. 0.45 rad for l from 1e-6
// to 1e-9, theta at 0.1 s 24 % low at 1e-9). The uplift starts at chi0 with psi = 0 (or pi), chi_dot = 0 and
// psi_dot = l/chi0^2 (y = 0, y' = +-l/chi0): theta_dot = 0 as in Housner's
// model, theta = +-alpha chi0. With chi0 = sqrt(l), psi turns at a rate 1
// (normalised) while x grows from chi0 in the time t_g the table's excess
// acceleration (rate c, normalised) needs to move it that far, t_g ~
// (6 chi0 / c)^(1/3) ~ l^(1/6); the ray leaves turned by ~ l^(1/6) (measured
// on figure 8's first uplift: 0.033 rad at l = 1e-7, 0.015 at 1e-9), which
// changes theta at second order, and the offset alpha sqrt(l) vanishes too
// (2.4e-6 rad for block 1 at l = 1e-10). chi0 = 0.3 sqrt(l) loses figure 7
// at l = 1e-10 (the turn is 11 times larger), 1 .. 3 sqrt(l) give the same
// peaks within 0.3 % at l <= 3e-10 (README, "The models").
// Free starts (Reset with theta0 or theta_dot0) take y = 0 and the
// transverse velocity l/chi (theta0 != 0), or start on the crossing at
// y = -l / chi_dot (theta0 = 0).
//
// Return to rest (ERRATA item 6). Near the floor V_min the motion is eq.
// (10)'s rest orbit, a circle crossing x = 0 twice per turn for ever, which
// Housner's model would call endless impacts. At a crossing whose
// regularised energy
//   e = (x'^2 + y'^2)/2 + (cos(alpha - alpha chi) - cos(alpha))/alpha^2
// (E / (M g R alpha^2) with the transverse motion) is below kRestEnergy
// V_min the block returns to rest (besides the impact-interval rule).
//
// Opt-in approximation (ModelOptions::complex_resolved_energy = K > 0): below
// K V_min the model integrates eq. (10)'s l -> 0 limit, Housner's equations
// in x (y = 0, the side fixed, impact x -> 0 with x' <- mu x'); it switches
// to eq. (10) when |x| rises through kResolvedChi chi_m with e >= K V_min
// (y' = l/x added: the centrifugal energy V_min/108), and back to the limit
// at a crossing with e < K V_min / 2 (leaving it with the energy
// mu (e - V_min)). Uplift then starts in the limit. Every sample says which
// equations produced it (ModelState::equations).

#include <algorithm>
#include <cmath>

#include "model/numbers.h"
#include "model/rocking_impl.h"

namespace rocklab::model::detail {
namespace {

// Hand-off radius of the opt-in approximation, in units of chi_m.
constexpr double kResolvedChi = 6.0;
// Back to rest at a crossing below this multiple of V_min (see above).
constexpr double kRestEnergy = 2.0;
// Absolute tolerance on x, y (and on x', y' / p) per unit l: with 1e-3 the
// energy ratio across one impact stayed 1.5e-5 below its l -> 0 value at
// l = 1e-10; with 1e-5 1.6e-6, with 1e-7 2.1e-7, at the same CPU time.
constexpr double kAtolPerL = 1e-7;

class ComplexModel final : public CvodeRockingModel {
 public:
  ComplexModel(const BlockParams& params, const ModelOptions& options)
      : CvodeRockingModel(params, options), damping_(2.0 * std::log(params.mu) / kPi) {
    const double a = params.alpha;
    const double l = options.l;
    chi_m_ = std::cbrt(l * l * a / std::sin(a));
    v_min_ = Potential(chi_m_) + 0.5 * l * l / (chi_m_ * chi_m_);
    handoff_ = options.complex_resolved_energy > 0.0;
    resolved_energy_ = options.complex_resolved_energy * v_min_;
    limit_ = handoff_;
    // A crossing passes the origin at the distance l / v (v <~ 1): the
    // position tolerance must resolve it, and the transverse velocity, ~ l/chi
    // away from the origin, carries the angular momentum l.
    const double pos = std::min(options.atol / a, kAtolPerL * l);
    const double vel = std::min(options.atol / a, kAtolPerL * l * params.p);
    const double atol[4] = {pos, pos, vel, vel};
    Init(4, atol);
  }
  ModelKind kind() const override { return ModelKind::kComplex; }

 protected:
  void RockingRhs(double t_s, const double* y, double* ydot) override {
    const double a = params_.alpha;
    const double p2 = params_.p * params_.p;
    const double forcing = -table_accel(t_s) / (kGravity * a);  // a / (g alpha)
    ydot[0] = y[2];
    ydot[1] = y[3];
    if (limit_) {
      const double chi = std::abs(y[0]);
      ydot[2] = p2 * (-std::sin(a - a * chi) / a * side_ + forcing * std::cos(a - a * chi));
      ydot[3] = 0.0;
      return;
    }
    const double chi = std::hypot(y[0], y[1]);
    if (!(chi > 0.0)) {
      // Only a state without angular momentum reaches the origin; CVODE
      // retries with a smaller step.
      ydot[2] = ydot[3] = 0.0;
      return;
    }
    const double chi_dot = (y[0] * y[2] + y[1] * y[3]) / (chi * params_.p);  // normalised
    const double force = -std::sin(a - a * chi) / a + damping_ * options_.l * chi_dot / (chi * chi) +
                         forcing * std::cos(a - a * chi) * (y[0] / chi);
    ydot[2] = p2 * force * y[0] / chi;
    ydot[3] = p2 * force * y[1] / chi;
  }
  void RockingRoots(const double* y, double* g) const override {
    g[0] = y[0];  // x through 0: psi through pi/2 + k pi
    if (limit_) {
      g[1] = params_.alpha * std::abs(y[0]) - kPi / 2;
      g[2] = side_ * y[0] - kResolvedChi * chi_m_;  // rising: maybe resolved
    } else {
      g[1] = params_.alpha * std::hypot(y[0], y[1]) - kPi / 2;
      g[2] = 1.0;
    }
  }
  int ImpactRootDirection() const override { return limit_ ? -side_ : 0; }
  void InitialState(double theta0, double theta_dot0, int side, double* y) override {
    const double a = params_.alpha;
    const double p = params_.p;
    const double l = options_.l;
    side_ = side;
    const double x = theta0 / a, u = theta_dot0 / a;
    limit_ = handoff_ && !(std::abs(x) >= kResolvedChi * chi_m_ &&
                           Energy(std::abs(x), u, 0.0) >= resolved_energy_);
    if (limit_) {
      y[0] = x;
      y[1] = 0.0;
      y[2] = u;
      y[3] = 0.0;
    } else if (theta0 == 0.0 && theta_dot0 == 0.0) {
      // Uplift: a small chi on the uplift side, psi = 0 or pi, chi_dot = 0.
      const double chi0 = SeedRadius();
      y[0] = side * chi0;
      y[1] = 0.0;
      y[2] = 0.0;
      y[3] = side * p * l / chi0;
    } else if (theta0 != 0.0) {
      y[0] = x;
      y[1] = 0.0;
      y[2] = u;
      y[3] = p * l / x;  // x y' - y x' = l (normalised)
    } else {
      y[0] = 0.0;
      y[1] = -p * l / u;  // on the crossing, at the distance l / chi_dot
      y[2] = u;
      y[3] = 0.0;
    }
  }
  bool ApplyImpact(double* y) override {
    if (limit_) {
      y[0] = 0.0;
      y[2] *= params_.mu;
      side_ = -side_;
      return true;
    }
    if (!handoff_) return false;  // the impact is in the ODE
    const double e = Energy(std::hypot(y[0], y[1]), y[2], y[3]);
    if (e >= 0.5 * resolved_energy_) return false;
    // Leave the crossing in the direction of travel, in the l -> 0 limit.
    const double e_out = params_.mu * std::max(e - v_min_, 0.0);
    side_ = y[2] >= 0.0 ? +1 : -1;
    y[0] = y[1] = y[3] = 0.0;
    y[2] = side_ * params_.p * std::sqrt(2.0 * e_out);
    limit_ = true;
    return true;
  }
  bool RestAtImpact(const double* y) const override {
    if (limit_) return false;  // Housner's rule (impact interval) only
    return Energy(std::hypot(y[0], y[1]), y[2], y[3]) < kRestEnergy * v_min_;
  }
  bool ApplySwitch(double* y) override {
    if (!limit_ || Energy(std::abs(y[0]), y[2], 0.0) < resolved_energy_) return false;
    y[1] = 0.0;
    y[3] = params_.p * options_.l / y[0];
    limit_ = false;
    return true;
  }
  void FillState(const double* y) override {
    const double a = params_.alpha;
    state_.chi = limit_ ? std::abs(y[0]) : std::hypot(y[0], y[1]);
    state_.psi = limit_ ? (side_ > 0 ? 0.0 : kPi) : std::atan2(y[1], y[0]);
    state_.theta = a * y[0];
    state_.theta_dot = a * y[2];
    state_.equations = limit_ ? Equations::kLimit : Equations::kEq10;
  }
  Equations RestEquations() const override { return handoff_ ? Equations::kLimit : Equations::kEq10; }

 private:
  // sqrt(l) > chi_m = l^(2/3) (alpha / sin alpha)^(1/3) for every l < 1.
  double SeedRadius() const { return std::max(chi_m_, std::sqrt(options_.l)); }
  double Potential(double chi) const {
    const double a = params_.alpha;
    return (std::cos(a - a * chi) - std::cos(a)) / (a * a);
  }
  // Regularised energy (normalised) at radius chi with velocities u, v
  // (dx/dtau, dy/dtau).
  double Energy(double chi, double u, double v) const {
    const double p2 = params_.p * params_.p;
    return 0.5 * (u * u + v * v) / p2 + Potential(chi);
  }

  double damping_;            // 2 ln(mu) / pi, ERRATA item 3
  double chi_m_{};            // radius of the rest orbit, 1
  double v_min_{};            // the regularised energy there, 1
  bool handoff_{false};       // the opt-in l -> 0 hand-off is on
  double resolved_energy_{};  // hand-off: eq. (10) above it, the limit below half of it, 1
  bool limit_{false};         // integrating the l -> 0 limit (hand-off only)
  int side_{+1};              // limit: the side x is on (+1 / -1)
};

}  // namespace

std::unique_ptr<RockingModel> MakeComplex(const BlockParams& params, const ModelOptions& options) {
  return std::make_unique<ComplexModel>(params, options);
}

}  // namespace rocklab::model::detail
