#include "daq/savitzky_golay.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/QR>

namespace rocklab::daq {
namespace {

// weights[d](p, i): derivative d at sample p of `n` uniformly spaced samples
// from the least-squares polynomial of degree `order`, per unit of dt^d.
void FitWeights(int n, int order, double dt_s, Eigen::MatrixXd (&weights)[3]) {
  // Scaled abscissae in [-1, 1] keep the normal equations well conditioned.
  const double centre = 0.5 * (n - 1);
  const double scale = std::max(1.0, centre);
  Eigen::MatrixXd a(n, order + 1);
  for (int i = 0; i < n; ++i) {
    const double x = (i - centre) / scale;
    for (int k = 0; k <= order; ++k) a(i, k) = std::pow(x, k);
  }
  // Coefficients = pinv * y.
  const Eigen::MatrixXd pinv = a.householderQr().solve(Eigen::MatrixXd::Identity(n, n));
  for (int d = 0; d < 3; ++d) {
    weights[d].setZero(n, n);
    const double unit = std::pow(scale * dt_s, d);
    for (int p = 0; p < n; ++p) {
      const double x = (p - centre) / scale;
      Eigen::RowVectorXd v = Eigen::RowVectorXd::Zero(order + 1);
      for (int k = d; k <= order; ++k) {
        double factor = 1;
        for (int j = 0; j < d; ++j) factor *= (k - j);
        v(k) = factor * std::pow(x, k - d);
      }
      weights[d].row(p) = v * pinv / unit;
    }
  }
}

}  // namespace

SavitzkyGolay::SavitzkyGolay(int half_window, int order, double dt_s)
    : m_(half_window), n_(2 * half_window + 1), order_(order), dt_s_(dt_s) {
  if (half_window < 1) throw std::invalid_argument("Savitzky-Golay: half_window must be >= 1");
  if (order < 2 || order >= n_) {
    throw std::invalid_argument("Savitzky-Golay: order must be in [2, 2 * half_window]");
  }
  if (!(dt_s > 0)) throw std::invalid_argument("Savitzky-Golay: dt_s must be > 0");
  FitWeights(n_, order_, dt_s_, weights_);
  for (int d = 0; d < 3; ++d) start_weights_[d].setZero(m_, n_);
  for (int j = 0; j < m_; ++j) {
    const int len = j + m_ + 1;
    Eigen::MatrixXd w[3];
    FitWeights(len, std::min(order_, len - 1), dt_s_, w);
    for (int d = 0; d < 3; ++d) start_weights_[d].row(j).head(len) = w[d].row(j);
  }
  ring_.assign(n_, 0.0);
}

Eigen::VectorXd SavitzkyGolay::CentreWeights(int deriv) const {
  return weights_[deriv].row(m_).transpose();
}

void SavitzkyGolay::Push(double value) {
  if (finished_) {
    finished_ = false;
    short_segment_ = false;
    seg_start_ = pushed_;
    next_out_ = ready_end_ = pushed_;
  }
  ring_[pushed_ % n_] = value;
  ++pushed_;
  ready_end_ = std::max(seg_start_, pushed_ - m_);
}

void SavitzkyGolay::Finish() {
  if (finished_) return;
  finished_ = true;
  const int64_t count = pushed_ - seg_start_;
  if (count == 0) return;
  if (count < n_) {
    short_segment_ = true;
    const int order = static_cast<int>(std::min<int64_t>(order_, count - 1));
    FitWeights(static_cast<int>(count), order, dt_s_, short_weights_);
  }
  ready_end_ = pushed_;
}

double SavitzkyGolay::Dot(const Eigen::MatrixXd& weights, int row, int64_t first, int len) const {
  double sum = 0;
  for (int i = 0; i < len; ++i) sum += weights(row, i) * ring_[(first + i) % n_];
  return sum;
}

bool SavitzkyGolay::Pop(SgOutput& out) {
  if (next_out_ >= ready_end_) return false;
  out.index = next_out_;
  const int64_t j = next_out_ - seg_start_;  // position in the segment
  const int64_t count = pushed_ - seg_start_;
  const Eigen::MatrixXd* w = weights_;
  int row = 0;
  int64_t first = pushed_ - n_;
  int len = n_;
  if (short_segment_ && j >= count - m_) {
    // The tail of a finished segment shorter than the window: one fit over it.
    w = short_weights_;
    row = static_cast<int>(j);
    first = seg_start_;
    len = static_cast<int>(count);
  } else if (j < m_) {
    w = start_weights_;
    row = static_cast<int>(j);
    first = seg_start_;
    len = static_cast<int>(j + m_ + 1);
  } else {
    row = static_cast<int>(next_out_ - first);  // m, or beyond m after Finish
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.value = Dot(w[0], row, first, len);
  out.d1 = len >= 2 ? Dot(w[1], row, first, len) : nan;
  out.d2 = len >= 3 ? Dot(w[2], row, first, len) : nan;
  ++next_out_;
  return true;
}

}  // namespace rocklab::daq
