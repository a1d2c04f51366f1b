#pragma once
/// @file
/// Calibration and per-sample reconstruction of the block's motion from the
/// raw channels (measurement models in DESIGN.md, rules in docs/acquisition.md).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "daq/rig_config.h"
#include "daq/source.h"

namespace rocklab::daq {

/// Bits of BlockState::flags: the FLAG_ constants of rocklab::block_state_t.
enum Flag : int32_t {
  kFlagSliding = 1,
  kFlagJump = 2,
  kFlagTwist = 4,
  kFlagOutOfPlane = 8,
  kFlagDisagree = 16,
  kFlagNoMirror = 32,
  kFlagNoCamera = 64,
};

/// One body's state at a sample of a multi-body rig (block_state2_t's
/// per-body fields, same names and meanings: angles absolute, theta > 0
/// tipping towards +x; sliding and jump relative to the body below, in its
/// frame, or to the table for the bottom body). NaN where unmeasured.
struct BodyState {
  double theta{};
  double theta_dot{};
  double theta_mirror{};
  double theta_camera{};
  double sliding{};       ///< m
  double jump{};          ///< m
  double twist{};         ///< rad
  double out_of_plane{};  ///< m
  double tilt{};          ///< rad
  double sigma_theta_camera{};  ///< rad
  double sigma_slide_m{};       ///< predicted noise of the relative pivot position (per axis), m
  int32_t leds_used{};
  int32_t flags{};
  int32_t checked{};
};

/// The block's state at one sample. NaN where a quantity cannot be measured.
/// In a multi-body rig the scalar fields are the bottom body's (bodies[0])
/// and `bodies` holds every body's.
struct BlockState {
  int64_t seq{};
  int64_t utime{};        ///< sample clock, us
  double time_s{};        ///< sample clock, s
  int64_t line{};         ///< line of the frame in its source
  double theta{};         ///< best rocking angle, rad (rule: docs/acquisition.md)
  double theta_dot{};     ///< rad/s (filled by the Processor's differentiator)
  double theta_mirror{};  ///< rad
  double theta_camera{};  ///< rad
  double sliding{};       ///< pivot x minus its rest x minus table displacement, m
  double jump{};          ///< pivot lift, m
  double twist{};         ///< rotation about the vertical, rad
  double out_of_plane{};  ///< mean out-of-plane displacement of the LED pair, m
  double tilt{};          ///< out-of-plane tilt from the mirror's orthogonal spot, rad
  double fit_rms_m{};     ///< RMS residual of the rigid fit, m
  double sigma_theta_camera{};  ///< predicted noise of theta_camera for the LEDs used, rad
  double sigma_pivot_m{};       ///< predicted noise of the pivot position (per axis), m
  double table_displacement{};  ///< calibrated table displacement, m (NaN if none)
  double table_acceleration{};  ///< calibrated accelerometer, m/s^2 (NaN if none)
  int32_t leds_used{};
  int32_t leds_invalid{};  ///< configured LEDs left out of the fit at this sample
  int32_t flags{};
  int32_t checked{};  ///< the check flags (sliding .. disagree) that were evaluated at this sample
  int32_t body_count{};  ///< bodies in `bodies`: 0 for a single-block rig (or a one-body one)
  /// Every body's state, bottom-up (empty for a single block: its copies
  /// cost nothing; a multi-body rig's reuse their storage once grown).
  std::vector<BodyState> bodies;
};

/// A least-squares rigid 2-D transform world = R(phi) model + t, phi
/// counter-clockwise in the (x, z) plane.
struct Rigid2d {
  double phi{};  ///< rad
  double tx{};   ///< m
  double tz{};   ///< m
  double rms{};  ///< RMS residual, m
  double cos_phi{};  ///< cos(phi), as the fit computed it
  double sin_phi{};  ///< sin(phi)
};
/// Closed-form 2-D Kabsch/Umeyama fit without scaling. `model` and `world`
/// hold n points as x0, z0, x1, z1, ...; n >= 2 and the model points distinct.
Rigid2d FitRigid2d(const double* model, const double* world, int n);

struct ReconstructionCounts {
  int64_t frames{};
  int64_t invalid_led_samples{};     ///< LED (x, z) pairs left out of fits
  int64_t invalid_mirror_samples{};  ///< frames with no valid mirror spot
  int64_t no_camera_frames{};        ///< frames with fewer than min_leds LEDs
  int64_t imprecise_pivot_frames{};  ///< fits whose pivot is too noisy for the sliding/jump checks
  int64_t no_theta_frames{};         ///< frames with neither mirror nor camera theta
};

/// Per-sample reconstruction. Holds only fixed-size state; Reconstruct does
/// not allocate (a multi-body rig's BlockState::bodies grow once, in the
/// first frame given that state, and keep their storage after).
class Reconstructor {
 public:
  /// Binds the rig's channels to the source's columns.
  /// @throws std::runtime_error "RIG:LINE: channel 'x' (sensor 'y') is not in SOURCE ..."
  Reconstructor(const RigConfig& rig, const std::vector<std::string>& source_channels,
                const std::string& source_path);

  /// Instantaneous state of one frame (theta_dot left NaN). Never throws.
  void Reconstruct(const Frame& frame, BlockState& out);

  const ReconstructionCounts& counts() const { return counts_; }
  bool has_table_displacement() const { return table_disp_.col >= 0; }
  bool has_accelerometer() const { return table_acc_.col >= 0; }

 private:
  struct Channel {
    int col{-1};
    double gain{1};
    double offset{};
    double raw_min{};
    double raw_max{};
    /// Calibrated value, NaN when absent, not finite, saturated or out of range.
    double Value(const Frame& frame) const;
  };
  struct Led {
    double x_m{};
    double z_m{};
    Channel x;
    Channel z;
    int body{};
  };
  Channel Bind(const RigConfig& rig, const std::string& sensor,
               const std::vector<std::string>& source_channels);
  struct Noise {
    double sigma_theta{};  ///< rad
    double sigma_pivot{};  ///< m
  };
  /// Predicted noise of the fit of `used` LEDs at model_xz for the point
  /// (px, pz) of the body frame (m): the pivot, or the face point of the body below.
  Noise PredictNoise(const double* model_xz, int used, double px, double pz) const;
  /// An out-of-plane LED pair bound to its channels.
  struct OutOfPlanePair {
    Channel a;
    Channel b;
    double spacing_m{};
    int body{};
  };
  /// The mirror's angle and tilt (a bad spot: kFlagNoMirror into flags,
  /// counted) and an out-of-plane pair's twist and displacement; what is
  /// unmeasurable is left as it was.
  void ReadMirror(const Frame& frame, double& theta_mirror, double& tilt, int32_t& flags);
  static void ReadOutOfPlane(const Frame& frame, const OutOfPlanePair& pair, double& twist, double& out_of_plane);
  /// A multi-body rig's frame: every body's fit and checks into out.bodies,
  /// the bottom body's into out's scalars.
  void ReconstructBodies(const Frame& frame, BlockState& out);

  CheckTolerances checks_;
  MirrorConfig mirror_;
  double pivot_half_width_m_{};
  int body_count_{0};  // 0: single block
  std::array<double, kMaxRigBodies> contact_half_width_m_{};  // per body, the pivots' |x|
  std::array<double, kMaxRigBodies> height_m_{};
  std::array<int, kMaxRigBodies + 1> body_begin_{};  // leds_ of body k: [begin[k], begin[k+1])
  int mirror_body_{0};
  std::vector<OutOfPlanePair> oop_;  // the rig's pairs (a single block's: at most one)
  Channel mirror_s_, mirror_n_, table_disp_, table_acc_;
  std::vector<Led> leds_;
  std::vector<double> model_xz_;  // scratch for the fit, sized once
  std::vector<double> world_xz_;
  double sigma_mirror_{};       // noise of theta_mirror, rad
  Noise all_leds_noise_[2]{};   // every LED valid: pivot at -x ([0]) and +x ([1])
  ReconstructionCounts counts_;
};

}  // namespace rocklab::daq
