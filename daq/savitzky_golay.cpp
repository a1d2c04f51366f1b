#include "daq/savitzky_golay.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include "common/units.h"

namespace rocklab::daq {
namespace {

using common::kNaN;

// In index order, as the estimate was always summed (same digits).
double Dot(const double* w, const double* y, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += w[i] * y[i];
  return sum;
}

}  // namespace

SavitzkyGolay::SavitzkyGolay(int half_window, int order, double dt_s, int lag)
    : m_(half_window), n_(2 * half_window + 1), lag_(lag), order_(order), dt_s_(dt_s) {
  if (half_window < 1 || half_window > kMaxHalfWindow) {
    throw std::invalid_argument("Savitzky-Golay: half_window must be in [1, " + std::to_string(kMaxHalfWindow) +
                                "]");
  }
  if (order < 2 || order > kMaxOrder || order >= n_) {
    throw std::invalid_argument("Savitzky-Golay: order must be in [2, min(6, 2 * half_window)]");
  }
  if (!(dt_s > 0) || !std::isfinite(dt_s)) throw std::invalid_argument("Savitzky-Golay: dt_s must be finite and > 0");
  if (lag < 0 || lag > half_window) throw std::invalid_argument("Savitzky-Golay: lag must be in [0, half_window]");
  q_.assign(static_cast<size_t>(n_) * (kMaxOrder + 1), 0.0);
  y_.assign(n_, 0.0);
  ring_.assign(2 * static_cast<size_t>(n_), 0.0);
  Poly basis;
  Basis(n_, order_, basis);
  for (int d = 0; d < 3; ++d) {
    centre_[d] = WindowWeights(basis, m_, d);
    at_lag_[d] = lag_ == m_ ? centre_[d] : WindowWeights(basis, n_ - 1 - lag_, d);
  }
}

Eigen::VectorXd SavitzkyGolay::WindowWeights(const Poly& basis, int p, int deriv) const {
  // With A = Q R, the fit's coefficients are R^-1 Q^T y, so the estimate
  // v^T c is (Q R^-T v)^T y: w = Q z with R^T z = v, v the derivative
  // `deriv` of the basis x^c at p: c! / (c - deriv)! x^(c - deriv) (at the
  // centre, x = 0: deriv! where c = deriv, else 0).
  const double x = (p - basis.centre) / basis.scale;
  double v[kMaxOrder + 1] = {};
  double power = 1;  // x^(c - deriv)
  for (int c = deriv; c <= basis.degree; ++c, power *= x) {
    double factor = 1;
    for (int j = 0; j < deriv; ++j) factor *= (c - j);
    v[c] = factor * power / std::pow(basis.scale * dt_s_, deriv);
  }
  double z[kMaxOrder + 1] = {};
  for (int c = 0; c <= basis.degree; ++c) {  // forward substitution, R^T lower triangular
    double sum = v[c];
    for (int j = 0; j < c; ++j) sum -= r_[j][c] * z[j];
    z[c] = sum / r_[c][c];
  }
  Eigen::VectorXd w = Eigen::VectorXd::Zero(basis.len);
  for (int c = 0; c <= basis.degree; ++c) {
    for (int i = 0; i < basis.len; ++i) w(i) += q_[static_cast<size_t>(c) * n_ + i] * z[c];
  }
  return w;
}

void SavitzkyGolay::Basis(int len, int degree, Poly& poly) {
  poly.len = len;
  poly.degree = degree;
  poly.centre = 0.5 * (len - 1);
  // Scaled abscissae in [-1, 1] keep the basis well conditioned.
  poly.scale = std::max(1.0, poly.centre);
  for (int i = 0; i < len; ++i) {
    const double x = (i - poly.centre) / poly.scale;
    double power = 1;
    for (int c = 0; c <= degree; ++c, power *= x) q_[static_cast<size_t>(c) * n_ + i] = power;
  }
  for (int c = 0; c <= degree; ++c) {
    double* qc = &q_[static_cast<size_t>(c) * n_];
    for (int j = 0; j <= degree; ++j) r_[j][c] = 0;
    for (int pass = 0; pass < 2; ++pass) {  // twice is enough (Giraud et al.)
      for (int j = 0; j < c; ++j) {
        const double* qj = &q_[static_cast<size_t>(j) * n_];
        double dot = 0;
        for (int i = 0; i < len; ++i) dot += qj[i] * qc[i];
        for (int i = 0; i < len; ++i) qc[i] -= dot * qj[i];
        r_[j][c] += dot;
      }
    }
    double norm = 0;
    for (int i = 0; i < len; ++i) norm += qc[i] * qc[i];
    norm = std::sqrt(norm);
    r_[c][c] = norm;
    for (int i = 0; i < len; ++i) qc[i] /= norm;
  }
}

void SavitzkyGolay::Fit(int64_t first, int len, Poly& poly) {
  Basis(len, std::min(order_, len - 1), poly);
  const double* window = &ring_[static_cast<size_t>(first % n_)];
  for (int i = 0; i < len; ++i) y_[i] = window[i];
  double b[kMaxOrder + 1] = {};
  for (int c = 0; c <= poly.degree; ++c) {
    const double* qc = &q_[static_cast<size_t>(c) * n_];
    for (int i = 0; i < len; ++i) b[c] += qc[i] * y_[i];
  }
  for (int c = poly.degree; c >= 0; --c) {  // back substitution, R upper triangular
    double sum = b[c];
    for (int j = c + 1; j <= poly.degree; ++j) sum -= r_[c][j] * poly.coef[j];
    poly.coef[c] = sum / r_[c][c];
  }
}

double SavitzkyGolay::Evaluate(const Poly& poly, int p, int deriv) const {
  if (poly.len < deriv + 1) return std::numeric_limits<double>::quiet_NaN();
  const double x = (p - poly.centre) / poly.scale;
  double sum = 0;
  double power = 1;  // x^(c - deriv)
  for (int c = deriv; c <= poly.degree; ++c, power *= x) {
    double factor = 1;
    for (int j = 0; j < deriv; ++j) factor *= (c - j);
    sum += poly.coef[c] * factor * power;
  }
  return sum / std::pow(poly.scale * dt_s_, deriv);
}

Eigen::VectorXd SavitzkyGolay::CentreWeights(int deriv) const { return centre_[deriv]; }

Eigen::VectorXd SavitzkyGolay::LagWeights(int deriv) const { return at_lag_[deriv]; }

double SavitzkyGolay::NoiseGain(int deriv) const { return std::sqrt(at_lag_[deriv].squaredNorm()); }

void SavitzkyGolay::Push(double value) {
  if (finished_) {
    finished_ = false;
    seg_start_ = pushed_;
    next_out_ = ready_end_ = pushed_;
  }
  const size_t slot = static_cast<size_t>(pushed_ % n_);
  ring_[slot] = value;
  ring_[slot + static_cast<size_t>(n_)] = value;
  ++pushed_;
  ready_end_ = std::max(seg_start_, pushed_ - lag_);
}

void SavitzkyGolay::Finish() {
  if (finished_) return;
  finished_ = true;
  const int64_t count = pushed_ - seg_start_;
  if (count == 0) return;
  // The last full window (the whole segment when it is shorter) gives the
  // outputs the centred window cannot reach.
  tail_first_ = std::max(seg_start_, pushed_ - n_);
  Fit(tail_first_, static_cast<int>(pushed_ - tail_first_), tail_);
  ready_end_ = pushed_;
}

bool SavitzkyGolay::Pop(SgOutput& out) {
  if (next_out_ >= ready_end_) return false;
  out.index = next_out_;
  const int64_t j = next_out_ - seg_start_;  // position in the segment
  if (finished_ && next_out_ >= pushed_ - lag_) {
    const int p = static_cast<int>(next_out_ - tail_first_);
    out.value = want_[0] ? Evaluate(tail_, p, 0) : kNaN;
    out.d1 = want_[1] ? Evaluate(tail_, p, 1) : kNaN;
    out.d2 = want_[2] ? Evaluate(tail_, p, 2) : kNaN;
  } else {
    // The window whose newest sample is `lag` after the output (cut at the
    // segment's start). When outputs lag (several inputs pushed between
    // pops, as when a gap is bridged) its start may have left the ring: then
    // the latest window gives the output, off-centre, as at the end of a
    // segment.
    const bool cut = j < n_ - 1 - lag_;
    const int64_t first = cut ? seg_start_ : next_out_ + lag_ - (n_ - 1);
    const int64_t end = next_out_ + lag_ + 1;
    if (first >= pushed_ - n_ && !cut) {
      const double* window = &ring_[static_cast<size_t>(first % n_)];
      out.value = want_[0] ? Dot(at_lag_[0].data(), window, n_) : kNaN;
      out.d1 = want_[1] ? Dot(at_lag_[1].data(), window, n_) : kNaN;
      out.d2 = want_[2] ? Dot(at_lag_[2].data(), window, n_) : kNaN;
    } else {
      const int64_t from = first >= pushed_ - n_ ? first : std::max(seg_start_, pushed_ - n_);
      const int64_t to = first >= pushed_ - n_ ? end : pushed_;
      Fit(from, static_cast<int>(to - from), start_);
      const int p = static_cast<int>(next_out_ - from);
      out.value = want_[0] ? Evaluate(start_, p, 0) : kNaN;
      out.d1 = want_[1] ? Evaluate(start_, p, 1) : kNaN;
      out.d2 = want_[2] ? Evaluate(start_, p, 2) : kNaN;
    }
  }
  ++next_out_;
  return true;
}

}  // namespace rocklab::daq
