// The paper's complex formulation, eq. (10) as corrected in docs/errata.md
// items 3-5, integrated in Cartesian coordinates (x, y) = chi (cos psi,
// sin psi): the same equations, with theta = alpha x and an impact where x
// crosses 0. Two things to know before editing:
// - eq. (10) has no state of rest: an uplift starts at chi0 = sqrt(l) with
//   psi = 0 or pi, and the block returns to rest at a crossing whose energy
//   is below kRestEnergy V_min (docs/errata.md item 6);
// - crossings of the origin are integrated in a frame turned onto the line
//   of the motion, matched to Binet's solution where that is exact; an
//   asymmetric section restarts the integrator at each crossing.
// Derivations and measured accuracy: docs/models.md, "The complex
// formulation in model/complex.cpp".

#include <algorithm>
#include <array>
#include <cmath>

#include "model/numbers.h"
#include "model/rocking_impl.h"

namespace rocklab::model::detail {
namespace {

// Hand-off radius of the opt-in approximation, in units of chi_m.
constexpr double kResolvedChi = 6.0;
// Back to rest at a crossing below this multiple of V_min (docs/models.md).
constexpr double kRestEnergy = 2.0;
// Absolute tolerance on x, y (and on x', y' / p) per unit l: a crossing
// integrated through (a slow one, see kCoreTolerance) passes the origin at
// the distance l / v.
constexpr double kAtolPerL = 1e-7;
// x = theta / alpha, 1: the impact root's shift in Housner's limit
// (kHousnerImpactSlackRad / alpha, the same 1e-14 rad order).
constexpr double kLimitImpactSlack = 1e-14;
// Matched passage (docs/models.md, "Crossings"): the radius where the outer
// integration hands over, r_m = kMatchPerSpeed2 v^2 (v the normalised
// speed), at most kMatchMaxChi: gravity changes the speed inside it by
// ~ kMatchPerSpeed2 relative, which the legs integrate.
constexpr double kMatchPerSpeed2 = 1e-3;
constexpr double kMatchMaxChi = 1e-3;
// The core of the passage (scale b = l / v) is eq. (10) without gravity and
// table (Binet's solution) when |D| l / v^3, the relative change of the
// crossing's energy ratio they make there, is below this; otherwise the
// crossing is integrated through.
constexpr double kCoreTolerance = 1e-10;
// ... and when the core is this much smaller than the match radius.
constexpr double kMinCoreRatio = 1e3;
// Absolute tolerance on the transverse coordinate y (and y' / p) per unit
// l outside crossings, in the frame of the line: y is O(l) there and only
// carries the angular momentum, which a crossing does not depend on (its
// damping takes the state's own); relative tolerance on it would make CVODE
// resolve the transverse drift to rtol (free rocking of block 1: 2946
// steps for 10 impacts against 819, the same impact times to 1e-11 s).
constexpr double kTransverseAtolPerL = 1e-2;
// kCoreTolerance and kTransverseAtolPerL were set for rtol 1e-10
// (simulate's default); a looser rtol scales the first by s = rtol /
// kToleranceRtol and the second by sqrt(s) (rtol 1e-6: 1e4 and 1e2). A
// matched core then errs by at most rtol in the crossing's energy ratio,
// and the transverse coordinate sets fewer of the steps that shrink with
// the distance on the way into every crossing. Measured (docs/performance.md,
// "The forced complex likelihood"): s itself on the transverse tolerance
// lets the line's turn drift (figure 8 at rtol 1e-6: 6.7e-5 rad against
// rtol 1e-12, 1.5e-7 unscaled, 1.3e-7 with sqrt(s)).
constexpr double kToleranceRtol = 1e-10;
// RK4 steps of each leg (entry radius to the origin, origin to exit): the
// legs are gravity and table along a ray over r_m, smooth on that scale.
constexpr int kLegSteps = 16;

// Binet's crossing (gravity and table left out) between two points at the
// same radius: u = 1/chi obeys u'' - D u' + u = 0 in psi, u = C e^(D psi / 2)
// sin(w psi). From u'/u = rho at the entry, the speed ratio exit / entry
// and the turn of the position angle between them.
struct BinetCrossing {
  double speed_ratio{};
  double turn_rad{};
};
BinetCrossing SolveBinet(double rho, double damping, double w) {
  const double wpsi_a = std::atan2(w, rho - damping / 2);
  const double psi_a = wpsi_a / w;
  const double sin_a = std::sin(wpsi_a);
  // Exit at psi_b = pi / w - eps with e^(D (psi_b - psi_a) / 2) sin(w psi_b) = sin(w psi_a).
  const double k = std::exp(damping * (kPi / w - psi_a) / 2);
  double eps = sin_a / (k * w);
  for (int i = 0; i < 50; ++i) {
    const double e = std::exp(-damping * eps / 2);
    const double f = k * e * std::sin(w * eps) - sin_a;
    const double df = k * e * (w * std::cos(w * eps) - damping / 2 * std::sin(w * eps));
    const double step = f / df;
    eps -= step;
    if (std::abs(step) <= 1e-16 * eps) break;
  }
  const double ratio_b = damping / 2 - w / std::tan(w * eps);  // u'/u at the exit
  BinetCrossing c;
  c.speed_ratio = std::sqrt((ratio_b * ratio_b + 1) / (rho * rho + 1));
  c.turn_rad = kPi / w - eps - psi_a;
  return c;
}

class ComplexModel final : public CvodeRockingModel {
 public:
  ComplexModel(const BlockParams& params, const ModelOptions& options) : CvodeRockingModel(params, options) {
    const double l = options.l;
    handoff_ = options.complex_resolved_energy > 0.0;
    double pos = kAtolPerL * l;
    double vel = kAtolPerL * l * params.p;
    for (int side : {+1, -1}) {
      const SideParams sp = params.Side(side);
      Side& s = sides_[side > 0 ? 0 : 1];
      s.alpha = sp.alpha;
      s.p = sp.p;
      s.p2 = sp.p * sp.p;
      s.mu = sp.mu;
      s.damping = 2.0 * std::log(sp.mu) / kPi;
      s.w2 = 1.0 - s.damping * s.damping / 4;
      s.w = std::sqrt(std::max(s.w2, 0.0));
      s.chi_m = std::cbrt(l * l * sp.alpha / std::sin(sp.alpha));
      s.v_min = Potential(s, s.chi_m) + 0.5 * l * l / (s.chi_m * s.chi_m);
      s.resolved_energy = options.complex_resolved_energy * s.v_min;
      // A crossing passes the origin at the distance l / v (v <~ 1): the
      // position tolerance must resolve it, and the transverse velocity, ~
      // l/chi away from the origin, carries the angular momentum l.
      pos = std::min(pos, options.atol / sp.alpha);
      vel = std::min({vel, options.atol / sp.alpha, kAtolPerL * l * sp.p});
    }
    const SideParams plus = params.Side(+1), minus = params.Side(-1);
    same_sides_ = plus.alpha == minus.alpha && plus.p == minus.p && plus.mu == minus.mu;
    limit_ = handoff_;
    const double tight[4] = {pos, pos, vel, vel};
    const double scale = std::max(1.0, options.rtol / kToleranceRtol);
    core_tolerance_ = kCoreTolerance * scale;
    const double transverse = kTransverseAtolPerL * std::sqrt(scale) * l;
    const double loose[4] = {pos, transverse, vel, transverse * params.p};
    std::copy(tight, tight + 4, atol_tight_);
    std::copy(loose, loose + 4, atol_loose_);
    Init(4, atol_tight_);
  }
  ModelKind kind() const override { return ModelKind::kComplex; }

 protected:
  void RockingRhs(double t_s, const double* y, double* ydot) override {
    const Side& s = S(side_);
    const double a = s.alpha;
    const double p2 = s.p2;
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
    const double chi_dot = (y[0] * y[2] + y[1] * y[3]) / (chi * s.p);  // normalised
    // The state's own angular momentum (normalised), l on the exact
    // solution: with it the damping of a crossing does not depend on how
    // well the integration kept l (a crossing is scale-free in l).
    const double momentum = (y[0] * y[3] - y[1] * y[2]) / s.p;
    // The restitution of the pivot the motion heads for (see above).
    const double damping = S(ActualX(y[2], y[3]) >= 0.0 ? +1 : -1).damping;
    const double force = -std::sin(a - a * chi) / a + damping * momentum * chi_dot / (chi * chi) +
                         forcing * std::cos(a - a * chi) * (ActualX(y[0], y[1]) / chi);
    ydot[2] = p2 * force * y[0] / chi;
    ydot[3] = p2 * force * y[1] / chi;
  }
  void RockingRoots(const double* y, double* g) const override {
    const Side& s = S(side_);
    // x through 0: psi through pi/2 + k pi. In Housner's limit (the opt-in
    // hand-off) x starts at 0 at an uplift or an impact: shifted towards the
    // side by kLimitImpactSlack, as Housner's model does (housner.cpp), so a
    // motion that leaves towards the other side at once still crosses it.
    if (limit_) {
      g[0] = y[0] + side_ * kLimitImpactSlack;
      g[1] = s.alpha * std::abs(y[0]) - kPi / 2;
      g[2] = side_ * y[0] - kResolvedChi * s.chi_m;  // rising: maybe resolved
    } else {
      const double chi = std::hypot(y[0], y[1]);
      g[0] = ActualX(y[0], y[1]);
      g[1] = s.alpha * chi - kPi / 2;
      g[2] = chi - MatchRadius(s, y[2], y[3]);  // falling: a crossing to match; rising: realign
    }
  }
  // x on side s leaves it only through s x falling; a symmetric block in eq.
  // (10) does not restart at a crossing, so both directions.
  int ImpactRootDirection() const override { return limit_ || !same_sides_ ? -side_ : 0; }
  int SwitchRootDirection() const override { return limit_ ? +1 : 0; }
  void InitialState(double theta0, double theta_dot0, int side, double* y) override {
    const Side& s = S(side);
    const double a = s.alpha;
    const double p = s.p;
    const double l = options_.l;
    side_ = side;
    SetFrame(0.0);
    const double x = theta0 / a, u = theta_dot0 / a;
    limit_ = handoff_ && !(std::abs(x) >= kResolvedChi * s.chi_m &&
                           Energy(s, std::abs(x), u, 0.0) >= s.resolved_energy);
    Aligned();
    if (limit_) {
      y[0] = x;
      y[1] = 0.0;
      y[2] = u;
      y[3] = 0.0;
    } else if (theta0 == 0.0 && theta_dot0 == 0.0) {
      // Uplift: a small chi on the uplift side, psi = 0 or pi, chi_dot = 0.
      // The ray turns by ~ l^(1/6) while the block leaves chi0: realigned
      // where it leaves the match radius.
      const double chi0 = SeedRadius(s);
      y[0] = side * chi0;
      y[1] = 0.0;
      y[2] = 0.0;
      y[3] = side * p * l / chi0;
      Misaligned();
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
      Misaligned();
    }
  }
  bool ApplyImpact(double* y) override {
    const Side& from = S(side_);
    const Side& to = S(-side_);
    if (limit_) {
      y[0] = 0.0;
      y[2] *= to.mu;
      if (!same_sides_) y[2] *= from.alpha / to.alpha;  // theta_dot continuous up to mu
      side_ = -side_;
      return true;
    }
    if (!handoff_ || Energy(from, std::hypot(y[0], y[1]), y[2], y[3]) >= 0.5 * from.resolved_energy) {
      // The impact is in the ODE (a crossing integrated through); an
      // asymmetric block continues on the other side from the similar state
      // (see above), in the unrotated frame.
      side_ = -side_;
      const bool changed = Misaligned();
      if (same_sides_) return changed;
      ToActual(y);
      const double c = (from.alpha * from.p) / (to.alpha * to.p);
      const double k = from.alpha / to.alpha;
      y[0] = 0.0;
      y[1] /= c;
      y[2] *= k;
      y[3] *= k;
      return true;
    }
    // Leave the crossing in the direction of travel, in the l -> 0 limit, with
    // the energy mu (e - V_min) (in the landing side's units: theta_dot
    // continuous, normalised speeds * c).
    ToActual(y);
    const double e = Energy(from, std::hypot(y[0], y[1]), y[2], y[3]);
    side_ = y[2] >= 0.0 ? +1 : -1;
    const Side& land = S(side_);
    const double c = (from.alpha * from.p) / (land.alpha * land.p);
    const double e_out = land.mu * std::max(e - from.v_min, 0.0) * c * c;
    y[0] = y[1] = y[3] = 0.0;
    y[2] = side_ * land.p * std::sqrt(2.0 * e_out);
    limit_ = true;
    return true;
  }
  bool RestAtImpact(const double* y) const override {
    if (limit_) return false;  // Housner's rule (impact interval) only
    const Side& s = S(side_);
    return Energy(s, std::hypot(y[0], y[1]), y[2], y[3]) < kRestEnergy * s.v_min;
  }
  SwitchResult ApplySwitch(double t_s, double* y, Passage* passage) override {
    const Side& s = S(side_);
    if (limit_) {
      if (Energy(s, std::abs(y[0]), y[2], 0.0) < s.resolved_energy) return SwitchResult::kNone;
      y[1] = 0.0;
      y[3] = s.p * options_.l / y[0];
      limit_ = false;
      Misaligned();
      return SwitchResult::kReinit;
    }
    const double chi = std::hypot(y[0], y[1]);
    const double radial = (y[0] * y[2] + y[1] * y[3]) / chi;  // d chi / d tau, 1/s
    if (radial >= 0.0) {
      // Leaving the match radius: turn the frame onto the ray, so the
      // transverse coordinates are O(l) again and x y' - y x' keeps its digits.
      if (!misaligned_) return SwitchResult::kNone;
      const double transverse = (y[0] * y[3] - y[1] * y[2]) / chi;
      const double psi = Angle(y[0], y[1]);
      SetFrame(psi);
      y[0] = chi;
      y[1] = 0.0;
      y[2] = radial;
      y[3] = transverse;
      Aligned();
      return SwitchResult::kReinit;
    }
    if (PlanPassage(t_s, y, passage)) return SwitchResult::kPassage;
    // Integrated through (tight tolerances: a restart), realigned on the way out.
    return Misaligned() ? SwitchResult::kReinit : SwitchResult::kNone;
  }
  void FillPassageState(double t_s) override {
    const bool in = t_s < plan_.t_impact_s;
    const Leg& leg = in ? plan_.in : plan_.out;
    // Cubic Hermite in time between the leg's nodes (s and ds/dtau).
    int i = 0;
    while (i + 1 < kLegSteps && leg.t_s[static_cast<std::size_t>(i + 1)] <= t_s) ++i;
    const auto k = static_cast<std::size_t>(i);
    const double sign = in ? -1.0 : 1.0;
    const double t0 = leg.t_s[k], t1 = leg.t_s[k + 1];
    const double h = t1 - t0;
    const double u = h > 0.0 ? std::clamp((t_s - t0) / h, 0.0, 1.0) : 0.0;
    const double s0 = leg.s[k], s1 = leg.s[k + 1];
    const double d0 = sign * leg.speed[k] * h, d1 = sign * leg.speed[k + 1] * h;
    const double u2 = u * u, u3 = u2 * u;
    const double pos = (2 * u3 - 3 * u2 + 1) * s0 + (u3 - 2 * u2 + u) * d0 + (-2 * u3 + 3 * u2) * s1 + (u3 - u2) * d1;
    const double dpos = h > 0.0 ? ((6 * u2 - 6 * u) * s0 + (3 * u2 - 4 * u + 1) * d0 + (-6 * u2 + 6 * u) * s1 +
                                   (3 * u2 - 2 * u) * d1) / h
                                : sign * leg.speed[k];
    const double a = S(leg.side).alpha;
    state_.chi = std::max(pos, 0.0);
    state_.psi = Wrap(leg.ray_rad);
    state_.theta = a * state_.chi * std::cos(leg.ray_rad);
    state_.theta_dot = a * dpos * std::cos(leg.ray_rad);
    state_.equations = Equations::kEq10;
  }
  void FinishPassage(double* y) override {
    side_ = plan_.out.side;
    SetFrame(plan_.out.ray_rad);
    for (int i = 0; i < 4; ++i) y[i] = plan_.exit[i];
    Aligned();
  }
  void FillState(const double* y) override {
    const double a = S(side_).alpha;
    if (limit_) {
      state_.chi = std::abs(y[0]);
      state_.psi = side_ > 0 ? 0.0 : kPi;
      state_.theta = a * y[0];
      state_.theta_dot = a * y[2];
      state_.equations = Equations::kLimit;
      return;
    }
    state_.chi = std::hypot(y[0], y[1]);
    state_.psi = Angle(y[0], y[1]);
    state_.theta = a * ActualX(y[0], y[1]);
    state_.theta_dot = a * ActualX(y[2], y[3]);
    state_.equations = Equations::kEq10;
  }
  Equations RestEquations() const override { return handoff_ ? Equations::kLimit : Equations::kEq10; }

 private:
  // What eq. (10) needs of one side (one pivot).
  struct Side {
    double alpha{};            // rad
    double p{};                // rad/s
    double p2{};               // p^2, rad^2/s^2
    double mu{};               // restitution of a landing on this pivot, 1
    double damping{};          // 2 ln(mu) / pi, docs/errata.md item 3
    double w2{};               // 1 - damping^2 / 4
    double w{};                // Binet's frequency sqrt(w2), 1
    double chi_m{};            // radius of the rest orbit, 1
    double v_min{};            // the regularised energy there, 1
    double resolved_energy{};  // hand-off: eq. (10) above it, the limit below half of it, 1
  };
  // One leg of a matched passage: along a ray, between the match radius and
  // the origin; nodes of (time, radius, speed).
  struct Leg {
    std::array<double, kLegSteps + 1> t_s{};    // s
    std::array<double, kLegSteps + 1> s{};      // chi, 1
    std::array<double, kLegSteps + 1> speed{};  // |d chi / d tau|, 1/s
    double ray_rad{};                           // position angle of the ray (actual frame), rad
    int side{};                                 // pivot side while on it
  };
  struct PassagePlan {
    Leg in, out;
    double t_impact_s{};
    double exit[4]{};  // state at the exit in the frame of the outgoing ray
  };

  const Side& S(int side) const { return sides_[side > 0 ? 0 : 1]; }
  // sqrt(l) > chi_m = l^(2/3) (alpha / sin alpha)^(1/3) for every l < 1.
  double SeedRadius(const Side& s) const { return std::max(s.chi_m, std::sqrt(options_.l)); }
  static double Potential(const Side& s, double chi) {
    const double a = s.alpha;
    return (std::cos(a - a * chi) - std::cos(a)) / (a * a);
  }
  // Regularised energy (normalised) on side s at radius chi with velocities
  // u, v (dx/dtau, dy/dtau).
  static double Energy(const Side& s, double chi, double u, double v) {
    return 0.5 * (u * u + v * v) / s.p2 + Potential(s, chi);
  }
  static double MatchRadius(const Side& s, double u, double v) {
    return std::min(kMatchPerSpeed2 * (u * u + v * v) / s.p2, kMatchMaxChi);
  }
  static double Wrap(double angle) { return std::remainder(angle, 2 * kPi); }

  // The integration frame is the actual (x, y) plane turned by phi_: the
  // state's first axis follows the line of the motion, so the transverse
  // coordinates stay O(l) after the line has precessed (pi (1/w - 1) per
  // crossing) and the angular momentum x y' - y x' = l keeps its digits.
  // The frame follows the line (loose transverse tolerance) or not (tight,
  // realigned where the motion leaves the match radius).
  void Aligned() {
    misaligned_ = false;
    if (tight_) SetAbsTolerances(atol_loose_);
    tight_ = false;
  }
  // Returns whether the tolerances changed (SUNDIALS 6.4 takes new
  // tolerances only at a re-initialisation: the caller restarts there).
  bool Misaligned() {
    misaligned_ = true;
    if (tight_) return false;
    SetAbsTolerances(atol_tight_);
    tight_ = true;
    return true;
  }
  void SetFrame(double phi) {
    phi_ = phi;
    cos_phi_ = std::cos(phi);
    sin_phi_ = std::sin(phi);
  }
  double ActualX(double xf, double yf) const { return cos_phi_ * xf - sin_phi_ * yf; }
  double ActualY(double xf, double yf) const { return sin_phi_ * xf + cos_phi_ * yf; }
  double Angle(double xf, double yf) const { return Wrap(phi_ + std::atan2(yf, xf)); }
  void ToActual(double* y) {
    const double x = ActualX(y[0], y[1]), yy = ActualY(y[0], y[1]);
    const double u = ActualX(y[2], y[3]), v = ActualY(y[2], y[3]);
    y[0] = x;
    y[1] = yy;
    y[2] = u;
    y[3] = v;
    SetFrame(0.0);
  }

  // Radial acceleration along a ray (gravity and table; the crossing's core
  // is Binet's), 1/s^2.
  double LegAcceleration(const Side& s, double chi, double t_s, double cos_ray) const {
    const double a = s.alpha;
    const double f = -table_accel(t_s) / (kGravity * a);
    return s.p2 * (-std::sin(a - a * chi) / a + f * std::cos(a - a * chi) * cos_ray);
  }
  // Integrates a leg by RK4 in the distance travelled (energy and time as
  // functions of it); false when the motion turns back on the way.
  bool IntegrateLeg(Leg& leg, double r_m, double t0_s, double speed0, bool inward) const {
    const Side& s = S(leg.side);
    const double cos_ray = std::cos(leg.ray_rad);
    const double h = r_m / kLegSteps;
    double e = 0.5 * speed0 * speed0, t = t0_s;
    auto rhs = [&](double sigma, double e_now, double t_now, double& de, double& dt) {
      if (!(e_now > 0.0)) return false;
      const double chi = inward ? r_m - sigma : sigma;
      const double acc = LegAcceleration(s, chi, t_now, cos_ray);
      de = inward ? -acc : acc;
      dt = 1.0 / std::sqrt(2.0 * e_now);
      return true;
    };
    for (int i = 0; i <= kLegSteps; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const double sigma = i * h;
      leg.t_s[k] = t;
      leg.s[k] = inward ? r_m - sigma : sigma;
      if (!(e > 0.0)) return false;
      leg.speed[k] = std::sqrt(2.0 * e);
      if (i == kLegSteps) break;
      double de1, dt1, de2, dt2, de3, dt3, de4, dt4;
      if (!rhs(sigma, e, t, de1, dt1) || !rhs(sigma + h / 2, e + h / 2 * de1, t + h / 2 * dt1, de2, dt2) ||
          !rhs(sigma + h / 2, e + h / 2 * de2, t + h / 2 * dt2, de3, dt3) ||
          !rhs(sigma + h, e + h * de3, t + h * dt3, de4, dt4)) {
        return false;
      }
      e += h / 6 * (de1 + 2 * de2 + 2 * de3 + de4);
      t += h / 6 * (dt1 + 2 * dt2 + 2 * dt3 + dt4);
    }
    leg.s[0] = inward ? r_m : 0.0;
    leg.s[kLegSteps] = inward ? 0.0 : r_m;
    return true;
  }

  // The crossing from the match radius, in closed form where its core is
  // Binet's (docs/models.md, "Crossings"): the ray in (gravity and table,
  // RK4), the core (speed times Binet's ratio, line turned by Binet's turn,
  // theta_dot continuous onto the landing pivot), the ray out. False where
  // that does not hold; the crossing is then integrated through.
  bool PlanPassage(double t_s, const double* y, Passage* passage) {
    const Side& from = S(side_);
    const Side& to = S(-side_);
    if (!(from.w2 > 0.0) || !(to.w2 > 0.0)) return false;  // mu < e^-pi: no crossing in Binet's form
    const double chi = std::hypot(y[0], y[1]);
    const double radial = (y[0] * y[2] + y[1] * y[3]) / chi;
    const double momentum = (y[0] * y[3] - y[1] * y[2]) / from.p;  // normalised
    if (!(momentum != 0.0)) return false;
    PassagePlan& plan = plan_;
    plan.in.ray_rad = Angle(y[0], y[1]);
    plan.in.side = side_;
    if (!IntegrateLeg(plan.in, chi, t_s, -radial, true)) return false;
    const double core_speed = plan.in.speed[kLegSteps] / from.p;  // normalised
    const double core = std::abs(momentum) / core_speed;          // b = l / v
    if (chi < kMinCoreRatio * core) return false;
    if (std::abs(to.damping) * std::abs(momentum) / (core_speed * core_speed * core_speed) > core_tolerance_) {
      return false;
    }
    const BinetCrossing binet = SolveBinet(chi / core, to.damping, to.w);
    plan.out.ray_rad = Wrap(plan.in.ray_rad + (momentum > 0.0 ? binet.turn_rad : -binet.turn_rad));
    plan.out.side = std::cos(plan.out.ray_rad) >= 0.0 ? +1 : -1;
    if (plan.out.side != -side_) return false;  // the line near x = 0 (after ~2000 crossings)
    plan.t_impact_s = plan.in.t_s[kLegSteps];
    const double speed_out = plan.in.speed[kLegSteps] * binet.speed_ratio * from.alpha / to.alpha;
    if (!IntegrateLeg(plan.out, chi, plan.t_impact_s, speed_out, false)) return false;
    // Exit in the frame of the outgoing ray, with the angular momentum l.
    plan.exit[0] = chi;
    plan.exit[1] = 0.0;
    plan.exit[2] = plan.out.speed[kLegSteps];
    plan.exit[3] = (momentum > 0.0 ? 1.0 : -1.0) * to.p * options_.l / chi;
    passage->t_entry_s = t_s;
    passage->t_impact_s = plan.t_impact_s;
    passage->t_exit_s = plan.out.t_s[kLegSteps];
    passage->impact_theta_dot = -from.alpha * plan.in.speed[kLegSteps] * std::cos(plan.in.ray_rad);
    passage->after_theta_dot = to.alpha * plan.out.speed[0] * std::cos(plan.out.ray_rad);
    return true;
  }

  Side sides_[2];            // [0]: the +x pivot (theta > 0), [1]: the -x pivot
  bool same_sides_{true};    // both sides have the same alpha, p and mu
  bool handoff_{false};      // the opt-in l -> 0 hand-off is on
  bool limit_{false};        // integrating the l -> 0 limit (hand-off only)
  int side_{+1};             // the side x is on (+1 / -1), switched at each crossing
  double phi_{};             // the integration frame's turn, rad
  double cos_phi_{1.0};
  double sin_phi_{0.0};
  bool misaligned_{false};   // the frame no longer follows the line: realign leaving r_m
  PassagePlan plan_;         // the pending passage's legs
  double atol_tight_[4]{};   // while a crossing is integrated through
  double atol_loose_[4]{};   // elsewhere: the transverse coordinates to 1e-2 l
  bool tight_{true};
  double core_tolerance_{kCoreTolerance};  // kCoreTolerance scaled with rtol (above)
};

}  // namespace

std::unique_ptr<RockingModel> MakeComplex(const BlockParams& params, const ModelOptions& options) {
  return std::make_unique<ComplexModel>(params, options);
}

}  // namespace rocklab::model::detail
