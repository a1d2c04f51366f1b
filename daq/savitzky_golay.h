#pragma once
/// @file
/// Streaming Savitzky-Golay smoothing differentiator: a least-squares
/// polynomial of degree `order` over a window of 2m+1 uniformly spaced samples
/// gives the smoothed value and its first and second derivatives, evaluated at
/// the sample `lag` samples behind the window's newest (0 <= lag <= m; the
/// default lag = m is the window's centre, the classic filter). Causality: the
/// output for sample k is available when sample k+lag has arrived, a constant
/// delay of `lag` samples, so outputs stream one per input. A lag below m
/// trades noise and bias for latency: the polynomial is evaluated
/// off-centre, where its noise gain (NoiseGain) is larger for the first
/// derivative (not always for the second: docs/acquisition.md). Near the
/// start of a segment the
/// window is cut to the samples available ([start, k+lag]); at its end
/// (Finish) the last full window is evaluated off-centre, which releases the
/// last `lag` outputs at once. Every input gets exactly one output.
/// Polynomials up to degree `order` are reproduced exactly at any lag (order
/// is lowered only where a window has fewer than order+1 samples).
///
/// Cost: construction is O(n order^2) time and O(n) memory (n = 2m+1; one
/// least-squares basis for the weights at the centre and at the lag), an
/// output in the stream O(n) (one dot product per derivative in use), each of
/// the first 2m-lag outputs of a segment one fit over its cut window
/// (O(n order^2)), and Finish one fit whose polynomial gives the last `lag`
/// outputs (docs/reliability.md has what a tabulated set-up cost). half_window
/// is bounded by kMaxHalfWindow.

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
  /// Largest half window accepted, samples (a 20001-sample window).
  static constexpr int kMaxHalfWindow = 10000;
  /// Largest polynomial order accepted.
  static constexpr int kMaxOrder = 6;

  /// The centred filter (lag = half_window).
  /// @param half_window m, samples; 1 <= m <= kMaxHalfWindow
  /// @param order polynomial degree; 2 <= order <= kMaxOrder, order < 2m+1 (the second derivative needs 2)
  /// @param dt_s sample spacing, s; > 0
  /// @throws std::invalid_argument naming the argument.
  SavitzkyGolay(int half_window, int order, double dt_s) : SavitzkyGolay(half_window, order, dt_s, half_window) {}
  /// @param lag samples between an output's sample and the newest sample of
  ///        its window (the output delay); 0 <= lag <= half_window
  /// @throws std::invalid_argument naming the argument.
  SavitzkyGolay(int half_window, int order, double dt_s, int lag);

  /// Adds the next sample of the current segment (after Finish: of a new one).
  /// Outputs not popped before a new segment starts are discarded.
  void Push(double value);
  /// Ends the segment (end of data, or a gap): its last m outputs become available.
  void Finish();
  /// Next available output, oldest first. No allocation. The estimates not
  /// selected by SetOutputs are NaN.
  bool Pop(SgOutput& out);
  /// Which estimates Pop computes (all three by default): a caller that uses
  /// only the derivatives saves the other dot products.
  void SetOutputs(bool value, bool d1, bool d2) { want_[0] = value, want_[1] = d1, want_[2] = d2; }

  /// Output delay, samples: the lag.
  int delay_samples() const { return lag_; }
  int half_window() const { return m_; }
  /// Index the next Push will get.
  int64_t next_index() const { return pushed_; }
  /// Weights of the centred estimate of derivative `deriv` (0, 1, 2), per
  /// sample, oldest first, already divided by dt^deriv.
  Eigen::VectorXd CentreWeights(int deriv) const;
  /// Weights of the estimate of derivative `deriv` (0, 1, 2) at the lag, the
  /// ones every output in the stream uses (CentreWeights when lag = m).
  Eigen::VectorXd LagWeights(int deriv) const;
  /// Noise gain of the estimate at the lag: the standard deviation of the
  /// output per unit standard deviation of white input noise,
  /// sqrt(sum of the squared LagWeights), in 1/s^deriv.
  double NoiseGain(int deriv) const;

 private:
  // A least-squares polynomial in x = (p - centre) / scale over a window.
  struct Poly {
    double coef[kMaxOrder + 1]{};
    int degree{};
    int len{};
    double centre{};
    double scale{1};
  };
  // Orthonormalises the basis 1, x, .., x^degree over `len` positions in q_
  // (modified Gram-Schmidt, twice) and keeps R in r_.
  void Basis(int len, int degree, Poly& poly);
  // Least-squares polynomial through the `len` inputs from index `first`
  // (degree min(order_, len - 1)).
  void Fit(int64_t first, int len, Poly& poly);
  // Derivative `deriv` of `poly` at window position p, per s^deriv.
  double Evaluate(const Poly& poly, int p, int deriv) const;
  // With the basis of the full window in q_ and r_ (Basis(n_, order_, .)):
  // the weights of derivative `deriv` at position p of the window.
  Eigen::VectorXd WindowWeights(const Poly& basis, int p, int deriv) const;

  int m_;
  int n_;  // window length 2m+1
  int lag_;
  int order_;
  double dt_s_;
  Eigen::VectorXd centre_[3];  // weights of the centred estimate, per derivative
  Eigen::VectorXd at_lag_[3];  // weights at the lag (window position 2m - lag), per derivative
  // Scratch of Fit (sized once): the window's basis, orthonormalised in place.
  std::vector<double> q_;  // column k at q_[k * n_]
  std::vector<double> y_;
  double r_[kMaxOrder + 1][kMaxOrder + 1]{};
  Poly start_;  // scratch for the first m outputs of a segment
  Poly tail_;   // the fit (made by Finish) that gives a finished segment's last m outputs
  int64_t tail_first_{};
  // The last n_ inputs twice over (input i at i % n_ and i % n_ + n_), so
  // every window is contiguous: ring_[(first % n_) .. + n_).
  std::vector<double> ring_;
  bool want_[3]{true, true, true};  // value, d1, d2 computed by Pop
  int64_t pushed_{0};     // inputs since construction
  int64_t seg_start_{0};  // index of the segment's first input
  int64_t next_out_{0};
  int64_t ready_end_{0};  // outputs [next_out_, ready_end_) can be popped
  bool finished_{false};
};

}  // namespace rocklab::daq
