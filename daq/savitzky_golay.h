#pragma once
/// @file
/// Streaming Savitzky-Golay smoothing differentiator: a least-squares
/// polynomial of degree `order` over a window of 2m+1 uniformly spaced samples,
/// evaluated at the window's centre, gives the smoothed value and its first
/// and second derivatives. Causality: the output for sample k is available
/// when sample k+m has arrived, a constant delay of m samples, so outputs
/// stream one per input. Near the start of a segment the window is cut to the
/// samples available ([start, k+m]); at its end (Finish) the last full window
/// is evaluated off-centre, which releases the last m outputs at once. Every
/// input gets exactly one output. Polynomials up to degree `order` are
/// reproduced exactly (order is lowered only where a window has fewer than
/// order+1 samples).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace rocklab::daq {

struct SgOutput {
  int64_t index{};  ///< index of the input sample (counting every Push since construction)
  double value{};   ///< smoothed value, unit of the input
  double d1{};      ///< first derivative, unit/s
  double d2{};      ///< second derivative, unit/s^2
};

class SavitzkyGolay {
 public:
  /// @param half_window m, samples; >= 1
  /// @param order polynomial degree; 2 <= order < 2m+1 (the second derivative needs 2)
  /// @param dt_s sample spacing, s; > 0
  /// @throws std::invalid_argument naming the argument.
  SavitzkyGolay(int half_window, int order, double dt_s);

  /// Adds the next sample of the current segment (after Finish: of a new one).
  /// Outputs not popped before a new segment starts are discarded.
  void Push(double value);
  /// Ends the segment (end of data, or a gap): its last m outputs become available.
  void Finish();
  /// Next available output, oldest first. No allocation except after Finish
  /// of a segment shorter than the window.
  bool Pop(SgOutput& out);

  int delay_samples() const { return m_; }
  /// Index the next Push will get.
  int64_t next_index() const { return pushed_; }
  /// Weights of the centred estimate of derivative `deriv` (0, 1, 2), per
  /// sample, oldest first, already divided by dt^deriv.
  Eigen::VectorXd CentreWeights(int deriv) const;

 private:
  // sum_i weights(row, i) * input[first + i], i < len.
  double Dot(const Eigen::MatrixXd& weights, int row, int64_t first, int len) const;

  int m_;
  int n_;  // window length 2m+1
  int order_;
  double dt_s_;
  // Weights for each evaluation position p = 0..n-1 within a full window:
  // row p of weights_[d] gives derivative d at sample p of the window.
  Eigen::MatrixXd weights_[3];
  // Row j: sample j of a segment from the window [0, j+m] (j < m).
  Eigen::MatrixXd start_weights_[3];
  Eigen::MatrixXd short_weights_[3];  // for a finished segment shorter than the window
  std::vector<double> ring_;
  int64_t pushed_{0};     // inputs since construction
  int64_t seg_start_{0};  // index of the segment's first input
  int64_t next_out_{0};
  int64_t ready_end_{0};  // outputs [next_out_, ready_end_) can be popped
  bool finished_{false};
  bool short_segment_{false};
};

}  // namespace rocklab::daq
