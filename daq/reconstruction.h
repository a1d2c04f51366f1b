#pragma once
/// @file
/// Calibration and per-sample reconstruction of the block's motion from the
/// raw channels (measurement models in DESIGN.md, rules in docs/acquisition.md).

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

/// The block's state at one sample. NaN where a quantity cannot be measured.
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
/// not allocate.
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
  };
  Channel Bind(const RigConfig& rig, const std::string& sensor,
               const std::vector<std::string>& source_channels);
  struct Noise {
    double sigma_theta{};  ///< rad
    double sigma_pivot{};  ///< m
  };
  /// Predicted noise of the fit of `used` LEDs at model_xz with the pivot at x = bx (m).
  Noise PredictNoise(const double* model_xz, int used, double bx) const;

  CheckTolerances checks_;
  MirrorConfig mirror_;
  OutOfPlaneConfig oop_;
  double pivot_half_width_m_{};
  Channel mirror_s_, mirror_n_, oop_a_, oop_b_, table_disp_, table_acc_;
  std::vector<Led> leds_;
  std::vector<double> model_xz_;  // scratch for the fit, sized once
  std::vector<double> world_xz_;
  double sigma_mirror_{};       // noise of theta_mirror, rad
  Noise all_leds_noise_[2]{};   // every LED valid: pivot at -x ([0]) and +x ([1])
  ReconstructionCounts counts_;
};

}  // namespace rocklab::daq
