#include "daq/savitzky_golay.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rocklab::daq {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// In index order, as the estimate was always summed (same digits).
double Dot(const double* w, const double* y, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += w[i] * y[i];
  return sum;
}

}  // namespace

SavitzkyGolay::SavitzkyGolay(int half_window, int order, double dt_s)
    : m_(half_window), n_(2 * half_window + 1), order_(order), dt_s_(dt_s) {
  if (half_window < 1 || half_window > kMaxHalfWindow) {
    throw std::invalid_argument("Savitzky-Golay: half_window must be in [1, " + std::to_string(kMaxHalfWindow) +
                                "]");
  }
  if (order < 2 || order > kMaxOrder || order >= n_) {
    throw std::invalid_argument("Savitzky-Golay: order must be in [2, min(6, 2 * half_window)]");
  }
  if (!(dt_s > 0) || !std::isfinite(dt_s)) throw std::invalid_argument("Savitzky-Golay: dt_s must be finite and > 0");
  q_.assign(static_cast<size_t>(n_) * (kMaxOrder + 1), 0.0);
  y_.assign(n_, 0.0);
  ring_.assign(2 * static_cast<size_t>(n_), 0.0);
  // Centre weights: with A = Q R, the fit's coefficients are R^-1 Q^T y, so
  // the estimate v^T c is (Q R^-T v)^T y: w = Q z with R^T z = v.
  Poly centre;
  Basis(n_, order_, centre);
  const int k = order_;
  for (int d = 0; d < 3; ++d) {
    double v[kMaxOrder + 1] = {};
    // Derivative d of x^c at the centre (x = 0): d! where c = d, else 0.
    double factorial = 1;
    for (int j = 2; j <= d; ++j) factorial *= j;
    v[d] = factorial / std::pow(centre.scale * dt_s_, d);
    double z[kMaxOrder + 1] = {};
    for (int c = 0; c <= k; ++c) {  // forward substitution, R^T lower triangular
      double sum = v[c];
      for (int j = 0; j < c; ++j) sum -= r_[j][c] * z[j];
      z[c] = sum / r_[c][c];
    }
    centre_[d].setZero(n_);
    for (int c = 0; c <= k; ++c) {
      for (int i = 0; i < n_; ++i) centre_[d](i) += q_[static_cast<size_t>(c) * n_ + i] * z[c];
    }
  }
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
  ready_end_ = std::max(seg_start_, pushed_ - m_);
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
  if (finished_ && next_out_ >= pushed_ - m_) {
    const int p = static_cast<int>(next_out_ - tail_first_);
    out.value = want_[0] ? Evaluate(tail_, p, 0) : kNaN;
    out.d1 = want_[1] ? Evaluate(tail_, p, 1) : kNaN;
    out.d2 = want_[2] ? Evaluate(tail_, p, 2) : kNaN;
  } else {
    // The window centred on the output (cut at the segment's start). When
    // outputs lag (several inputs pushed between pops, as when a gap is
    // bridged) its start may have left the ring: then the latest window
    // gives the output, off-centre, as at the end of a segment.
    const int64_t first = j < m_ ? seg_start_ : next_out_ - m_;
    const int64_t end = j < m_ ? seg_start_ + j + m_ + 1 : next_out_ + m_ + 1;
    if (first >= pushed_ - n_ && j >= m_) {
      const double* window = &ring_[static_cast<size_t>(first % n_)];
      out.value = want_[0] ? Dot(centre_[0].data(), window, n_) : kNaN;
      out.d1 = want_[1] ? Dot(centre_[1].data(), window, n_) : kNaN;
      out.d2 = want_[2] ? Dot(centre_[2].data(), window, n_) : kNaN;
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
