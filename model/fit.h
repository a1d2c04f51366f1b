#pragma once
/// @file
/// Identification of the block parameters (alpha, p, mu) from a recorded test.
///
/// - Impacts method (the paper's section 4, free rocking): impact times and
///   peaks from the record, least squares of the measured against the
///   predicted half-intervals over (alpha, p) with the corrected quarter time
///   (docs/errata.md item 2; eq. 13 as an option), the admissible-alpha check, mu_n
///   by eq. (14) (docs/errata.md item 7).
/// - Trajectory method (beyond the paper): least squares of the Housner
///   model's theta(t) against the whole record over (alpha, p, mu), free or
///   driven by the recorded table acceleration.
/// Both use Eigen's Levenberg-Marquardt (unsupported/Eigen/LevenbergMarquardt)
/// with central finite differences.
///
/// Every fit says what it knows: the noise of theta is estimated from the
/// record alone (EstimateThetaNoise) or stated (FeatureOptions::noise_rad),
/// propagated to the residuals the fit should reach with a right model, and
/// the whitened residuals are tested against chi-square with the fit's
/// degrees of freedom (FitResult::chi2, p_value, converged). Every fit starts
/// from several points (FitResult::starts) so that it does not stop in a
/// local minimum. Missing samples are bridged (impacts) or skipped
/// (trajectory) and counted.

#include <functional>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/block.h"
#include "model/cancel.h"
#include "model/excitation.h"
#include "model/test_record.h"

namespace rocklab::model {

/// The record cannot give an answer (never rocks, overturns, too few impacts,
/// alpha outside the admissible band, a fit that does not converge). The
/// message says why in one line, naming the record.
class FitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class QuarterTime { kExact, kSlender };
enum class FitMethod { kImpacts, kTrajectory };
/// "exact" / "slender"; "impacts" / "trajectory".
const char* ToString(QuarterTime q);
const char* ToString(FitMethod m);
/// A forced fit's table reading as `fit --table` names it: "spline",
/// "chord" (Catmull-Rom's cubic: "catmull-rom").
const char* TableReadingName(Interpolation i);
/// "spline" or "chord".
/// @throws std::invalid_argument for another name.
Interpolation ParseTableReading(const std::string& name);
/// @throws std::invalid_argument for another name.
QuarterTime ParseQuarterTime(const std::string& name);
FitMethod ParseFitMethod(const std::string& name);

/// Quarter time T(r), s: QuarterTimeExact or QuarterTimeSlender.
double QuarterTimeOf(QuarterTime kind, double alpha, double p, double r);

/// White-noise standard deviation of theta, rad, from the record's
/// high-frequency content alone (no model, no fit): for every three
/// consecutive samples equally spaced in time (steps equal to 1e-3, so a
/// missing sample never enters) the second difference
/// d2 = theta[k+1] - 2 theta[k] + theta[k-1]; for white noise of standard
/// deviation sigma, var(d2) = 6 sigma^2, while the motion adds only
/// theta'' dt^2 (1e-5 rad at 500 Hz for block 1); impacts are a few
/// samples. So sigma = 1.4826 median(|d2|) / sqrt(6) (the median absolute
/// value, scaled to a standard deviation for Gaussian noise). 0 for fewer
/// than 5 such triples.
double EstimateThetaNoise(const RockingRecord& record);

/// White-noise estimate of theta with its own uncertainty.
struct ThetaNoiseEstimate {
  double sigma_rad{};       ///< as EstimateThetaNoise, rad
  int differences{};        ///< second differences used
  /// Relative standard error of sigma_rad: 1.42 / sqrt(differences) (the
  /// scaled median of |d2| of white noise, measured by Monte Carlo over 600
  /// records of 500 .. 6000 samples: 1.38 .. 1.49 / sqrt(n); docs/fit_coverage.md).
  double relative_stderr{};
  /// The chi-square degrees of freedom with the same relative spread of
  /// sigma^2: 1 / (2 relative_stderr^2), about differences / 4.
  double dof{};
};
/// EstimateThetaNoise with the number of differences and its spread.
ThetaNoiseEstimate EstimateThetaNoiseDetail(const RockingRecord& record);

/// The former fixed acceptance threshold on residual_to_noise. The verdict
/// is now the chi-square test (FitOptions::significance); kept so that code
/// naming it still builds. A reduced chi-square of 1.5^2 is far outside the
/// noise for more than a few dozen degrees of freedom.
inline constexpr double kMaxResidualToNoise = 1.5;

/// Default significance of the goodness-of-fit test (FitOptions::significance).
inline constexpr double kDefaultSignificance = 0.01;

/// Upper tail P(X >= x) of Snedecor's F(d1, d2) by Paulson's normal
/// approximation (the Wilson-Hilferty cube root of both chi-squares; d2 =
/// infinity gives chi2(d1) / d1). Within 3e-3 of the printed tables for
/// d1 >= 3. NaN for d1 < 1 or d2 <= 0.
double FUpperTail(double x, double d1, double d2);

/// Standard errors need this many degrees of freedom (residuals minus
/// parameters): with fewer, s^2 = RSS / dof is itself too uncertain (with 1,
/// its relative standard error is 100 %) and they are withheld (NaN).
inline constexpr int kMinDofForStderr = 3;

/// A table acceleration beyond this makes a record forced, m/s^2: the
/// trajectory method drives the model with it, the impacts method refuses it.
inline constexpr double kForcedTableAccel = 0.05;

/// Block geometry of the test (a rectangle 2b x 2h with an optional 45 degree
/// base chamfer, as in RectangleBlock, or a polygon section).
struct FitGeometry {
  double width_m{};    ///< 2b, m
  double height_m{};   ///< 2h, m
  double chamfer_m{};  ///< chamfer leg, m
  /// When not empty, the section (PolygonBlock) instead of the rectangle;
  /// theory and band are those of its +x side.
  std::vector<Eigen::Vector2d> polygon_m{};
};

/// The admissible alpha band: alpha of the geometry with b -> b -+ band_m
/// (the paper's rule: +-1 cm on b). A polygon's x coordinates are scaled
/// about its centroid so that its +x pivot moves by -+band_m (for a plain
/// rectangle the same as b -+ band_m).
struct AlphaBand {
  double lo{};         ///< rad
  double geometric{};  ///< rad
  double hi{};         ///< rad
  double band_m{};     ///< m
};
/// @throws std::invalid_argument for a geometry RectangleBlock rejects or a
///         band that leaves no positive half-width.
AlphaBand AdmissibleAlphaBand(const FitGeometry& geometry, double band_m);

/// How impacts and peaks are found in a free-rocking record.
struct FeatureOptions {
  /// Zero-crossing hysteresis, rad; 0: 5 x the estimated noise.
  double hysteresis_rad{0.0};
  /// Samples within this time of a crossing enter its fit (at most a quarter
  /// of the distance to the neighbouring crossings), s.
  double crossing_window_s{0.02};
  /// Peaks below this end the usable decay, rad; 0: 20 x the estimated noise.
  double min_peak_rad{0.0};
  /// A hold of at least this long before the first impact makes the release
  /// identifiable, s.
  double min_hold_s{0.05};
  /// |theta| beyond this is an overturn when no geometry is known, rad.
  double overturn_rad{1.0};
  /// White-noise standard deviation of theta stated by the user, rad (then
  /// taken as exact in the goodness-of-fit test); 0: estimated from the
  /// record (EstimateThetaNoise).
  double noise_rad{0.0};
};

/// Impacts and peaks of a free-rocking record.
struct FreeRockingFeatures {
  double noise_rad{};       ///< white-noise standard deviation of theta (estimated or stated), rad
  /// Degrees of freedom of noise_rad^2 (ThetaNoiseEstimate::dof); infinity
  /// when stated.
  double noise_dof{std::numeric_limits<double>::infinity()};
  double hysteresis_rad{};  ///< used, rad
  double min_peak_rad{};    ///< used, rad
  /// Impact times t_1..t_N (zero crossings, sub-sample), s.
  std::vector<double> impact_time_s;
  /// Standard error of each impact time from the noise (the crossing fit's
  /// s^2 (J^T J)^-1 with s = noise_rad), s.
  std::vector<double> impact_time_stderr_s;
  /// Peak |theta| after each impact, rad: peak_rad[i] lies between
  /// impact_time_s[i] and impact_time_s[i + 1] (size N - 1).
  std::vector<double> peak_rad;
  /// Standard error of each peak from the noise (the quartic fit), rad.
  std::vector<double> peak_stderr_rad;
  /// r_0, the peak before the first impact (the release amplitude, or a
  /// fitted peak when the record starts before a peak), rad.
  std::optional<double> r0_rad;
  double r0_stderr_rad{};  ///< its standard error from the noise, rad
  /// Sign of theta before the first impact (+1 or -1; 0 when it never rocks).
  int first_sign{};
  /// Release time, s, when the record holds the block before letting go.
  std::optional<double> release_time_s;
  /// Its standard error from the onset fit, s.
  double release_time_stderr_s{};
  std::size_t hold_start_index{};  ///< first sample of the hold (when released)
  double max_abs_theta{};          ///< rad
  double max_abs_theta_time_s{};   ///< s
};

/// Finds the impacts (zero crossings with hysteresis, located by a two-sided
/// local quadratic least-squares fit with a common root), the peaks (local
/// quartic fit) and the release (onset fit after a hold).
/// Does not judge the result (FitImpacts does).
/// @param cancelled polled as FitOptions::cancelled (may be empty).
/// @throws Cancelled when it returns true.
FreeRockingFeatures ExtractFreeRocking(const RockingRecord& record, const FeatureOptions& options,
                                       const CancelHook& cancelled = {});

/// One line of the per-impact table.
struct ImpactRow {
  int n{};                          ///< impact number (0: the release)
  double time_s{};                  ///< impact (or release) time, s
  std::optional<double> peak_rad;   ///< r_n, peak |theta| after it, rad
  std::optional<double> mu_n;       ///< eq. (14), 1
  std::optional<double> tau_s;      ///< measured quarter time tau_n*, s
  std::optional<double> residual_s; ///< T(r_n) - tau_n* at the solution, s
  /// Standard deviation the noise alone gives tau_n* - T(r_n): from the
  /// impact (release) times' and the peak's standard errors, s.
  std::optional<double> noise_s;
};

/// One Levenberg-Marquardt iteration, for progress displays.
struct FitProgress {
  int iteration{};
  int evaluations{};         ///< residual evaluations so far (model runs for trajectory)
  double rms{};              ///< RMS residual (s for impacts, rad for trajectory)
  Eigen::VectorXd x;         ///< current parameters (alpha, p[, mu[, release time]])
  double elapsed_s{};        ///< wall clock since the fit started, s
};

struct FitOptions {
  QuarterTime quarter_time{QuarterTime::kExact};
  /// Geometry: start values of the trajectory method, the admissible band and
  /// the theoretical row of the output.
  std::optional<FitGeometry> geometry;
  double alpha_band_m{0.01};  ///< +- on b, m
  FeatureOptions features;
  /// Fewest impacts the impacts method accepts (>= 3).
  int min_impacts{4};
  /// Pair the release-to-first-impact time with r_0 when the release is
  /// identifiable: a hold, and a release time whose standard error from the
  /// onset fit is at most max_release_stderr_s (the precision of a crossing;
  /// a worse release time would dominate the sum of squares).
  bool use_release{true};
  double max_release_stderr_s{5e-4};  ///< s
  /// Trajectory method: CVODE relative tolerance of the Housner model.
  double rtol{1e-8};
  /// Trajectory method: start from these instead of impacts/geometry.
  std::optional<BlockParams> start;
  /// Largest number of residual evaluations (the trajectory method runs the
  /// model once per evaluation).
  int max_evaluations{600};
  /// Called after every LM iteration (may be empty). Must not throw.
  std::function<void(const FitProgress&)> on_progress;
  /// Polled by the fit's long work: every LM iteration and residual
  /// evaluation, and every 16 384 samples of the feature scan and of a
  /// model run (model/cancel.h). Returning true stops the fit with
  /// Cancelled.
  CancelHook cancelled;
  /// Goodness of fit: a fit is converged when the chi-square of its
  /// whitened residuals has an upper-tail probability of at least this under
  /// the hypothesis "the residuals are the noise", in (0, 0.5).
  double significance{kDefaultSignificance};
  /// Trajectory method: starts from the prior box screened (a Halton set;
  /// 0: none, only the impacts/geometry/given start). Impacts method: local
  /// minima of the alpha profile refined (>= 1).
  int starts{-1};  ///< -1: the method's default (trajectory 24, impacts 3)
  /// Forced trajectory fit (and the posterior's forced likelihood): how
  /// the table record is read between its samples. The spline (the
  /// default) for point samples, as a DAQ records them; the chord biased
  /// alpha low on them (mean z -0.62 over the coverage bench's 200 forced
  /// records, docs/fit_coverage.md). The chord for a record whose samples
  /// are least-squares chord values (the camera-rate merge of
  /// video/daq_sync), read as a spline they bias alpha the other way.
  Interpolation table_interpolation{Interpolation::kSpline};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// A trajectory fit's second minimum that fits the record as well
/// (FitResult::second_minimum).
struct SecondMinimum {
  BlockParams params;  ///< alpha (rad), p (rad/s), mu (1)
  double delta_chi2{};  ///< its chi-square above the answer's, 1
};

struct FitResult {
  FitMethod method{FitMethod::kImpacts};
  QuarterTime quarter_time{QuarterTime::kExact};
  BlockParams params;            ///< fitted alpha (rad), p (rad/s), mu (1)
  double mu_spread{};            ///< impacts: standard deviation of the mu_n, 1; trajectory: NaN
  /// rad. Trajectory: s^2 (J^T J)^-1. Impacts: the unweighted fit's
  /// sandwich covariance (J^T J)^-1 J^T S J (J^T J)^-1 with S the
  /// half intervals' covariance from the noise (neighbours share an impact),
  /// times chi2_per_dof when the chi-square test rejects the fit. NaN when withheld.
  double alpha_stderr{};
  double p_stderr{};             ///< rad/s
  /// 1. Trajectory: from s^2 (J^T J)^-1. Impacts: every impact time, the
  /// release time, r_0 and the peaks carried jointly (linearised) to the
  /// mean of the mu_n, directly by eq. (14) and through the fitted alpha.
  double mu_stderr{};
  double alpha_p_correlation{};  ///< from s^2 (J^T J)^-1 at the solution, in [-1, 1]
  /// Standard errors withheld (NaN) because dof < kMinDofForStderr.
  bool stderr_withheld{};
  /// The residual the noise alone gives one residual, in the units of
  /// rms_residual: the rms over the residuals of sigma_i, their standard
  /// deviations from the noise. Trajectory: sigma_i = noise_rad. Impacts:
  /// from the impact-time standard errors (0.25 (se_n^2 + se_n+1^2)), the
  /// release time's and the peak's (through dT/dr). NaN when dof < 1 or the
  /// noise is 0.
  double noise_residual{};
  /// sqrt(sum (residual_i / sigma_i)^2 / dof), the root of the reduced
  /// chi-square: about 1 (within ~1/sqrt(2 dof)) when the model follows the
  /// record to its noise; NaN when noise_residual is.
  double residual_to_noise{};
  /// Sum of the whitened residuals' squares: trajectory sum (r_i / sigma)^2;
  /// impacts r^T C^+ r with C = (I - H) S (I - H)^T the covariance the
  /// noise gives the unweighted fit's residuals (H its hat matrix, S the
  /// half intervals' covariance), chi2(dof) for a right model. NaN when
  /// not computable (no noise, dof < 1).
  double chi2{std::numeric_limits<double>::quiet_NaN()};
  double chi2_per_dof{std::numeric_limits<double>::quiet_NaN()};  ///< chi2 / dof
  /// P(F(dof, noise_dof) >= chi2_per_dof): the probability that the noise
  /// alone leaves a chi-square this large, the noise estimate's own spread
  /// included (noise_dof; chi2(dof) when the noise is stated).
  double p_value{std::numeric_limits<double>::quiet_NaN()};
  /// Trajectory method: the band test (docs/fit_coverage.md): the
  /// residuals' power in their low band (DCT coefficients up to band_hz,
  /// where the model's motion and so a model error lie) over their power
  /// above it, each per degree of freedom: F(band dof) for white noise,
  /// whatever its level. band_p_value is P(F >= band_ratio). A trajectory
  /// fit converges when both tests pass at half the significance each
  /// (Bonferroni). NaN when not computed (the impacts method).
  double band_ratio{std::numeric_limits<double>::quiet_NaN()};
  double band_p_value{std::numeric_limits<double>::quiet_NaN()};
  double band_hz{std::numeric_limits<double>::quiet_NaN()};  ///< the low band's top, Hz
  double significance{kDefaultSignificance};  ///< the test's level used
  double noise_dof{std::numeric_limits<double>::infinity()};  ///< of the noise estimate
  /// The least-squares iteration met its convergence test and the residuals
  /// are consistent with the noise (p_value >= significance, or not
  /// computable).
  bool converged{};
  /// Starting points tried: screened (trajectory: the Halton set and the
  /// method's own start; impacts: local minima of the alpha profile) and
  /// refined by Levenberg-Marquardt.
  int starts{};
  int starts_refined{};
  GapCount theta_gaps;  ///< missing theta samples of the record (bridged or skipped)
  GapCount table_gaps;  ///< missing table samples (read across as the others)
  Eigen::MatrixXd covariance;    ///< of the fitted parameters, in their order
  double rms_residual{};         ///< s (impacts) or rad (trajectory)
  int residuals{};               ///< number of residuals
  int dof{};                     ///< residuals - parameters
  int iterations{};
  int evaluations{};
  double runtime_s{};            ///< wall clock, s
  std::optional<AlphaBand> band;
  std::optional<BlockParams> theory;  ///< from the geometry
  FreeRockingFeatures features;       ///< impacts method (and trajectory from a free record)
  std::vector<ImpactRow> impacts;     ///< impacts method
  std::optional<double> release_time_s;  ///< trajectory from a hold: fitted release time, s
  bool forced{};                      ///< trajectory: driven by the table record
  /// Forced trajectory fit: how much the table record's sampling moves the
  /// model. The model runs on the table samples read as
  /// FitOptions::table_interpolation says; the same run on Catmull-Rom's
  /// cubic through them differs by about the larger of the two readings'
  /// errors (the chord's h^2/8 a'', or the spline's and the cubic's
  /// O(h^3..h^4)): the rms of that difference d over the residuals (rad),
  /// and the fitted values it shifts (the fit again on Catmull-Rom's cubic
  /// from the answer, minus that answer; for the spline while d is below a
  /// quarter of the noise, linearised, (J^T J)^-1 J^T d, as when the refit
  /// fails), which the standard errors above include in quadrature. NaN /
  /// zero for a free record.
  double table_interpolation_rad{std::numeric_limits<double>::quiet_NaN()};
  /// Trajectory fit: the lowest other minimum of the search more than 2
  /// stated errors away in some parameter whose chi-square is above the
  /// answer's by less than 3.84 (a 95 % likelihood interval at one degree
  /// of freedom): the record does not tell the two apart. None: no such.
  std::optional<SecondMinimum> second_minimum;
  /// Forced trajectory fit: how the table record was read between its
  /// samples (FitOptions::table_interpolation).
  Interpolation table_interpolation{Interpolation::kSpline};
  BlockParams table_interpolation_shift;  ///< alpha (rad), p (rad/s), mu (1)
  std::vector<std::string> warnings;
};

/// The paper's procedure on a free-rocking record. Missing samples are
/// bridged: crossings and peaks are fitted to the samples present.
/// @throws FitError when the record never rocks, overturns, is not free
///         rocking (a table acceleration beyond kForcedTableAccel, or half
///         intervals that no alpha below pi/2 explains), has fewer than
///         min_impacts usable impacts, the fit fails, or alpha falls outside
///         the admissible band (with geometry).
FitResult FitImpacts(const RockingRecord& record, const FitOptions& options);

/// Fits (alpha, p, mu) to theta(t) of the whole record with the Housner
/// model (rtol options.rtol), driven by the record's table acceleration
/// (read as options.table_interpolation says) when it has one. Missing samples are skipped (the residuals are at the
/// samples present). The record must start at rest (forced) or from a held
/// release (free; the release time is fitted too). Start values: options.start,
/// else the impacts method (free records), else the geometry.
/// @throws FitError as FitImpacts, or when there is no start value.
FitResult FitTrajectory(const RockingRecord& record, const FitOptions& options);

}  // namespace rocklab::model
