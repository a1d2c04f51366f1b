#include "model/stack.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/units.h"

namespace rocklab::model::stack {
namespace {

using V2 = Eigen::Vector2d;
using Row = Eigen::Matrix<double, 1, Eigen::Dynamic, Eigen::RowMajor, 1, kMaxBodies>;
using Jac = Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, kMaxBodies>;

V2 Turned(double theta, const V2& r) {
  const double c = std::cos(theta), s = std::sin(theta);
  return {c * r.x() - s * r.y(), s * r.x() + c * r.y()};
}
V2 Perp(const V2& v) { return {-v.y(), v.x()}; }  // turned by +90 degrees
double Cross(const V2& a, const V2& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

BlockParams FrameEquivalent(const Frame& f) {
  if (f.columns < 1) throw std::invalid_argument("frame: columns must be >= 1");
  const std::pair<const char*, double> fields[] = {{"column_width_m", f.column_width_m},
                                                   {"column_height_m", f.column_height_m},
                                                   {"column_mass_kg", f.column_mass_kg}};
  for (const auto& [name, v] : fields) {
    if (!(std::isfinite(v) && v > 0)) throw std::invalid_argument(std::string("frame: ") + name + " must be > 0");
  }
  if (!(std::isfinite(f.beam_mass_kg) && f.beam_mass_kg >= 0)) throw std::invalid_argument("frame: beam_mass_kg must be >= 0");
  const double b = f.column_width_m / 2, h = f.column_height_m / 2;
  const double alpha = std::atan2(b, h), gamma = f.beam_mass_kg / (f.columns * f.column_mass_kg);
  const double p = std::sqrt(3 * common::kGravity / (4 * std::hypot(b, h)));
  BlockParams params;
  params.alpha = alpha;
  params.p = p * std::sqrt((1 + 2 * gamma) / (1 + 3 * gamma));
  params.mu = (1 - 1.5 * std::pow(std::sin(alpha), 2) + 3 * gamma * std::cos(2 * alpha)) / (1 + 3 * gamma);
  return params;
}

Body Body::Rectangle(double width_m, double height_m, double mass_kg) {
  const double b = width_m / 2, h = height_m / 2;
  return {b, h, mass_kg, mass_kg * (b * b + h * h) / 3.0};
}

// One configuration in one mode: the contact points P_k, the centres of
// mass G_i, the bodies' angles, and per body the 2 x m Jacobian A_i of its
// centre's velocity and the 1 x m row E_i of its angular rate.
struct Stack::Geometry {
  int m{};
  std::array<int, kMaxBodies> dof{};  // generalised coordinate of each interface, -1 closed
  std::array<double, kMaxBodies> theta{};
  std::array<V2, kMaxBodies + 1> p{};  // contact points; p[n] the top of the last body (unused)
  std::array<V2, kMaxBodies> g{};
  std::array<Jac, kMaxBodies> a{};
  std::array<Row, kMaxBodies> e{};
};

Stack::Stack(std::vector<Body> bodies, std::vector<bool> glued)
    : bodies_(std::move(bodies)), glued_(std::move(glued)), n_(static_cast<int>(bodies_.size())) {
  if (n_ < 1 || n_ > kMaxBodies) {
    throw std::invalid_argument("stack: 1 to " + std::to_string(kMaxBodies) + " bodies, not " + std::to_string(n_));
  }
  for (int i = 0; i < n_; ++i) {
    const Body& b = body(i);
    for (double v : {b.half_width_m, b.half_height_m, b.mass_kg, b.inertia_kgm2}) {
      if (!(std::isfinite(v) && v > 0)) {
        throw std::invalid_argument("stack: body " + std::to_string(i + 1) +
                                    ": sizes, mass and inertia must be finite and > 0");
      }
    }
  }
  if (glued_.empty()) glued_.assign(static_cast<std::size_t>(n_), false);
  if (static_cast<int>(glued_.size()) != n_) throw std::invalid_argument("stack: one glued flag per interface");
  c_.push_back(bodies_[0].half_width_m);
  for (int k = 1; k < n_; ++k) c_.push_back(std::min(body(k - 1).half_width_m, body(k).half_width_m));
}

int Stack::Dofs(const Mode& mode) const {
  int m = 0;
  for (int k = 0; k < n_; ++k) m += mode[static_cast<std::size_t>(k)] != 0;
  return m;
}

void Stack::Describe(const Mode& mode, const Vec& q, Geometry& out) const {
  out.m = 0;
  double theta = 0;
  for (int k = 0; k < n_; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    out.dof[kk] = mode[kk] != 0 ? out.m++ : -1;
    if (out.dof[kk] >= 0) theta += q(out.dof[kk]);
    out.theta[kk] = theta;
  }
  // Contact points and centres: P_0 = (e_0, 0); G_i = P_i + R_i (-e_i, h_i);
  // P_i+1 = G_i + R_i (e_i+1, h_i), e_k = -s_k c_k the pivot's abscissa.
  auto pivot_x = [&](int k) { return -mode[static_cast<std::size_t>(k)] * c_[static_cast<std::size_t>(k)]; };
  out.p[0] = V2(pivot_x(0), 0.0);
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    const double h = body(i).half_height_m;
    out.g[ii] = out.p[ii] + Turned(out.theta[ii], V2(-pivot_x(i), h));
    const double above = i + 1 < n_ ? pivot_x(i + 1) : 0.0;
    out.p[ii + 1] = out.g[ii] + Turned(out.theta[ii], V2(above, h));
  }
  // The centre of body i moves with every body j <= i turning about its
  // contact point below: G_i' = sum_j theta_j' J W_ij, W_ij = P_j+1 - P_j
  // (j < i) or G_i - P_i (j = i); theta_j' = E_j q'.
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    out.e[ii] = Row::Zero(out.m);
    for (int k = 0; k <= i; ++k) {
      if (out.dof[static_cast<std::size_t>(k)] >= 0) out.e[ii](out.dof[static_cast<std::size_t>(k)]) = 1.0;
    }
    out.a[ii] = Jac::Zero(2, out.m);
    for (int j = 0; j <= i; ++j) {
      const auto jj = static_cast<std::size_t>(j);
      const V2 w = j < i ? V2(out.p[jj + 1] - out.p[jj]) : V2(out.g[ii] - out.p[ii]);
      out.a[ii] += Perp(w) * out.e[jj];
    }
  }
}

void Stack::Bodies(const Mode& mode, const Vec& q, const Vec& qdot, double* theta, double* theta_dot) const {
  Geometry geo;
  Describe(mode, q, geo);
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    theta[ii] = geo.theta[ii];
    theta_dot[ii] = geo.m > 0 ? geo.e[ii].dot(qdot) : 0.0;
  }
}

namespace {

// The part of body i's acceleration that is not A_i qddot: -sum_j
// theta_j'^2 W_ij (each contact point's centripetal term).
V2 Centripetal(const std::array<V2, kMaxBodies + 1>& p, const V2& g, const std::array<Row, kMaxBodies>& e,
               int i, const Vec& qdot) {
  V2 c(0, 0);
  for (int j = 0; j <= i; ++j) {
    const auto jj = static_cast<std::size_t>(j);
    const double w = qdot.size() > 0 ? e[jj].dot(qdot) : 0.0;
    const V2 arm = j < i ? V2(p[jj + 1] - p[jj]) : V2(g - p[jj]);
    c -= w * w * arm;
  }
  return c;
}

}  // namespace

Vec Stack::Accelerations(const Mode& mode, const Vec& q, const Vec& qdot, double table_accel_mps2) const {
  Geometry geo;
  Describe(mode, q, geo);
  Mat mass = Mat::Zero(geo.m, geo.m);
  Vec force = Vec::Zero(geo.m);
  if (geo.m == 0) return force;
  const V2 field(-table_accel_mps2, -common::kGravity);  // the table's push and gravity, per kg
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    const double m = body(i).mass_kg;
    mass += m * geo.a[ii].transpose() * geo.a[ii] + body(i).inertia_kgm2 * geo.e[ii].transpose() * geo.e[ii];
    const V2 c = Centripetal(geo.p, geo.g[ii], geo.e, i, qdot);
    force += m * geo.a[ii].transpose() * (field - c);
  }
  return mass.ldlt().solve(force);
}

void Stack::Loads(const Mode& mode, const Vec& q, const Vec& qdot, const Vec& qddot, double table_accel_mps2,
                  Load* loads) const {
  Geometry geo;
  Describe(mode, q, geo);
  // Body i needs m_i (G_i'' + (u_g'', g)) and I_i theta_i'' from outside;
  // summed over the bodies above interface k (moments about P_k), that is
  // what the body below gives them there.
  std::array<V2, kMaxBodies> need{};
  std::array<double, kMaxBodies> spin{};
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    const V2 acc = (geo.m > 0 ? V2(geo.a[ii] * qddot) : V2(0, 0)) + Centripetal(geo.p, geo.g[ii], geo.e, i, qdot) +
                   V2(table_accel_mps2, common::kGravity);
    need[ii] = body(i).mass_kg * acc;
    spin[ii] = body(i).inertia_kgm2 * (geo.m > 0 ? geo.e[ii].dot(qddot) : 0.0);
  }
  for (int k = 0; k < n_; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    V2 force(0, 0);
    double moment = 0;
    for (int i = k; i < n_; ++i) {
      const auto ii = static_cast<std::size_t>(i);
      force += need[ii];
      moment += Cross(geo.g[ii] - geo.p[kk], need[ii]) + spin[ii];
    }
    const double below = k > 0 ? geo.theta[kk - 1] : 0.0;
    loads[kk] = {force.dot(V2(-std::sin(below), std::cos(below))), moment};
  }
}

double Stack::Energy(const Mode& mode, const Vec& q, const Vec& qdot) const {
  Geometry geo;
  Describe(mode, q, geo);
  double energy = 0;
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    const V2 v = geo.m > 0 ? V2(geo.a[ii] * qdot) : V2(0, 0);
    const double w = geo.m > 0 ? geo.e[ii].dot(qdot) : 0.0;
    energy += 0.5 * body(i).mass_kg * v.squaredNorm() + 0.5 * body(i).inertia_kgm2 * w * w +
              body(i).mass_kg * common::kGravity * geo.g[ii].y();
  }
  return energy;
}

Stack::ImpactResult Stack::Impact(const Mode& mode, const Vec& q, const Vec& qdot, int k, double restitution) const {
  const auto kk = static_cast<std::size_t>(k);
  if (k < 0 || k >= n_ || mode[kk] == 0) throw std::invalid_argument("stack impact: interface is not pivoting");
  Geometry before;
  Describe(mode, q, before);
  std::array<V2, kMaxBodies> v_before{};
  std::array<double, kMaxBodies> w_before{};
  double scale = 0;  // momentum scale for the tolerances, kg m/s
  for (int i = 0; i < n_; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    v_before[ii] = before.a[ii] * qdot;
    w_before[ii] = before.e[ii].dot(qdot);
    scale += body(i).mass_kg * (v_before[ii].norm() + std::abs(w_before[ii]) * body(i).half_height_m);
  }
  const double tol = 1e-11 * scale;
  const double rate_k = qdot(before.dof[kk]);

  // Candidates, fewest contact changes first: k on its other corner or
  // closed, each closed, unglued interface kept closed or opened; then, last,
  // k kept on its corner (the striking corner taking no impulse), so that
  // every contact state of the contacts at zero gap is tried (docs/models.md,
  // "Impacts: the contact states after").
  std::vector<int> closed;
  for (int j = 0; j < n_; ++j) {
    if (j != k && mode[static_cast<std::size_t>(j)] == 0 && !glued(j)) closed.push_back(j);
  }
  std::vector<std::pair<int, Mode>> candidates;
  for (int sk : {-mode[kk], 0, mode[kk]}) {
    if (sk != 0 && glued(k)) continue;
    int combos = 1;
    for (std::size_t c = 0; c < closed.size(); ++c) combos *= 3;
    for (int code = 0; code < combos; ++code) {
      Mode next = mode;
      next[kk] = sk;
      int changes = (sk == 0) + (sk == mode[kk] ? 2 * n_ + 2 : 0), rest = code;
      for (int j : closed) {
        const int s = rest % 3 == 0 ? 0 : (rest % 3 == 1 ? 1 : -1);
        rest /= 3;
        next[static_cast<std::size_t>(j)] = s;
        changes += s != 0;
      }
      candidates.emplace_back(changes, next);
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });

  // The preload allowance of each interface (N s): the weight of the bodies
  // above it over kContactPreloadTimeS, the tensile impulse its standing
  // compression takes up in that time without the contact parting.
  std::array<double, kMaxBodies> allowance{};
  {
    double above = 0;
    for (int j = n_ - 1; j >= 0; --j) {
      above += body(j).mass_kg;
      allowance[static_cast<std::size_t>(j)] = kContactPreloadTimeS * common::kGravity * above;
    }
  }

  // Each candidate's post-impact state, and its worst shortfall from pushing
  // in units of the allowance (0: every impulse pushes to round-off); < 0
  // when an interface that opens here would not move apart.
  // With `hold_pivots` the interfaces pivoting before and after (not k) are
  // held: their normal impulse is not checked (no flight, as between
  // impacts, where a pivot's normal force is not either).
  auto evaluate = [&](const Mode& next, ImpactResult& out, bool hold_pivots) -> double {
    // The same configuration in the new mode's coordinates.
    out.mode = next;
    const int m = Dofs(next);
    out.q = Vec::Zero(m);
    for (int j = 0, d = 0; j < n_; ++j) {
      if (next[static_cast<std::size_t>(j)] == 0) continue;
      out.q(d++) = before.theta[static_cast<std::size_t>(j)] - (j > 0 ? before.theta[static_cast<std::size_t>(j - 1)] : 0.0);
    }
    Geometry after;
    Describe(next, out.q, after);
    // One equation per pivot of the new mode: the angular momentum of the
    // bodies above it about it is kept (or, at k with a restitution given,
    // its relative rate is the factor times the one before).
    Mat lhs = Mat::Zero(m, m);
    Vec rhs = Vec::Zero(m);
    for (int j = 0; j < n_; ++j) {
      const auto jj = static_cast<std::size_t>(j);
      const int row = after.dof[jj];
      if (row < 0) continue;
      if (j == k && restitution >= 0) {
        lhs(row, row) = 1.0;
        rhs(row) = restitution * rate_k;
        continue;
      }
      for (int i = j; i < n_; ++i) {
        const auto ii = static_cast<std::size_t>(i);
        const V2 r = after.g[ii] - after.p[jj];
        const double mi = body(i).mass_kg, ii_inertia = body(i).inertia_kgm2;
        lhs.row(row) += mi * (r.x() * after.a[ii].row(1) - r.y() * after.a[ii].row(0)) + ii_inertia * after.e[ii];
        rhs(row) += mi * Cross(r, v_before[ii]) + ii_inertia * w_before[ii];
      }
    }
    out.qdot = m > 0 ? Vec(lhs.partialPivLu().solve(rhs)) : Vec::Zero(0);

    double worst = 0;
    for (int j = 0; j < n_; ++j) {
      const auto jj = static_cast<std::size_t>(j);
      const int s = next[jj];
      // An interface that opens here must move apart.
      if (s != 0 && (j == k || mode[jj] == 0) && s * out.qdot(after.dof[jj]) < -1e-12 * (std::abs(rate_k) + 1)) {
        return -1.0;
      }
      // Impulses through it: pushing, and within a closed face.
      V2 impulse(0, 0);
      double moment = 0;
      for (int i = j; i < n_; ++i) {
        const auto ii = static_cast<std::size_t>(i);
        const V2 dv = (m > 0 ? V2(after.a[ii] * out.qdot) : V2(0, 0)) - v_before[ii];
        const double dw = (m > 0 ? after.e[ii].dot(out.qdot) : 0.0) - w_before[ii];
        impulse += body(i).mass_kg * dv;
        moment += body(i).mass_kg * Cross(after.g[ii] - after.p[jj], dv) + body(i).inertia_kgm2 * dw;
      }
      const double below = j > 0 ? before.theta[jj - 1] : 0.0;
      const double normal = impulse.dot(V2(-std::sin(below), std::cos(below)));
      if (hold_pivots && s != 0 && j != k && mode[jj] != 0) continue;
      worst = std::max(worst, (-normal - tol) / allowance[jj]);
      if (s == 0) worst = std::max(worst, (std::abs(moment) - c_[jj] * normal - tol * c_[jj]) / (c_[jj] * allowance[jj]));
    }
    return worst;
  };

  // The first candidate whose impulses all push (to round-off) is the
  // solution of the contacts' complementarity problem. Failing that, the
  // one of least shortfall, if its tensile impulses are within the preloads;
  // failing that, the same with the pivots above held (docs/models.md).
  for (bool hold_pivots : {false, true}) {
    ImpactResult best;
    double best_worst = std::numeric_limits<double>::infinity();
    for (const auto& [changes, next] : candidates) {
      (void)changes;
      ImpactResult out;
      const double worst = evaluate(next, out, hold_pivots);
      if (worst == 0.0) {  // in the second pass, pushing only with the pivots held
        out.rule = hold_pivots ? ImpactRule::kHeldPivots : ImpactRule::kPushing;
        return out;
      }
      if (worst > 0 && worst < best_worst) {
        best_worst = worst;
        best = out;
      }
    }
    if (best_worst <= 1.0) {
      best.rule = hold_pivots ? ImpactRule::kHeldPivots : ImpactRule::kPreload;
      return best;
    }
  }
  std::string state;
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    state += (i ? ", " : "") + std::to_string(q(i)) + " rad at " + std::to_string(qdot(i)) + " rad/s";
  }
  throw std::runtime_error("stack impact at interface " + std::to_string(k) + " (mode " + ModeName(mode, n_) +
                           "; relative angles " + state +
                           "): no post-impact contact state keeps every contact pushing, within each interface's preload over " +
                           std::to_string(kContactPreloadTimeS) + " s, even with the pivots held (a block would jump)");
}

}  // namespace rocklab::model::stack
