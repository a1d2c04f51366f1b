#pragma once
/// @file
/// A camera's `[camera.video]` section of the rig file (docs/video.md): how
/// its video is read, where its LEDs are looked for, the lens and the
/// reference marks that map the image to the rig plane. The daq/ parser
/// leaves the section to this one; the keys here are read and checked with
/// the file, line and key in every error, and unknown keys are errors.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "daq/rig_config.h"

namespace rocklab::video {

/// Pinhole intrinsics and OpenCV's distortion (k1, k2, p1, p2, k3), pixels.
struct Intrinsics {
  double fx_px{}, fy_px{}, cx_px{}, cy_px{};
  std::array<double, 5> distortion{};  ///< k1, k2, p1, p2, k3 (1)
  int width_px{}, height_px{};         ///< image size the calibration holds for; 0 = unknown
  double rms_reprojection_px{-1};      ///< from the calibration; < 0 = not known
  int views{};                         ///< chessboard views used; 0 = not known
};

/// Which light of a colour frame the LEDs are found in (`channel`): the
/// luma (grey, the default: 0.299 R + 0.587 G + 0.114 B), one channel, or
/// a weighted sum of R, G, B (clipped to 0..255). A one-channel video is
/// taken as it is.
struct ColourChoice {
  enum class Kind { kGrey, kChannel, kWeights };
  Kind kind{Kind::kGrey};
  int channel{};                    ///< kChannel: 0 red, 1 green, 2 blue
  std::array<double, 3> rgb{};      ///< kWeights: weights of R, G, B
  std::string Describe() const;     ///< "grey", "red", "0.5 R + 0.5 G + 0 B"
};

/// A reference mark on the rig plane: where it is in the image (as seen,
/// distorted) and where it is in the rig frame.
struct Mark {
  double u_px{}, v_px{};  ///< image column, row (pixel centres at integers)
  double x_m{}, z_m{};    ///< rig frame, m
  int line{};             ///< in the rig file
};

/// One LED of the camera and the rig channels its coordinates go to.
struct VideoLed {
  std::string name;
  double x_m{}, z_m{};  ///< block frame (= rig frame at rest), m
  /// The rig's channels for `<camera>.<led>.x|z`; the source delivers
  /// raw = (metres - offset) / gain, so the DAQ's calibration gives metres.
  const daq::ChannelConfig* x_channel{};  ///< non-owning, into the RigConfig
  const daq::ChannelConfig* z_channel{};
};

/// A sync LED in the camera's view driven by a DAQ channel (`sync = "led"`):
/// the video's clock is put on the DAQ's by its on/off edges
/// (video/daq_sync.h, `rocklab track --daq`).
struct SyncLedConfig {
  bool present{false};
  /// `sync = "table"`: no LED; the table's motion seen in the video (the
  /// pivot corner of the LEDs' rigid fit) against `channel`, the DAQ's
  /// table displacement (video/daq_sync.h, FitClockByMotion).
  bool by_table{false};
  double u_px{}, v_px{};   ///< its centre in the image (column, row), px
  int radius_px{3};        ///< its light is the mean of the (2r+1)^2 pixels around it
  std::string channel;     ///< the DAQ file's column that drives it
  int line{};              ///< of the `sync` key in the rig file
};

/// Reference marks from a printed ChArUco board laid on the rig plane
/// (`[camera.video.board]`, docs/video.md), instead of typed `mark`s: the
/// board's chessboard corners found in an image from the camera's place
/// (video/board_marks.h), each with its rig coordinates. The board's own
/// frame (OpenCV's): x along its rows of squares, y down its columns from
/// its top-left corner as printed; it hangs upright on the plane, so rig
/// x = origin x + board x and rig z = origin z - board y.
struct BoardConfig {
  bool present{false};
  std::string dictionary{"DICT_4X4_50"};  ///< OpenCV's predefined ArUco dictionary
  int squares_x{}, squares_y{};           ///< squares across and down
  double square_m{}, marker_m{};          ///< sides as printed (measure them), m
  double origin_x_m{}, origin_z_m{};      ///< rig coordinates of the board's top-left corner, m
  /// A still (image, or a video's first frame) of the board seen from the
  /// camera's place, path as given (relative to the rig file); empty: the
  /// video input's own first frame.
  std::string image;
  int min_corners{8};  ///< fewer corners found is an error
  int line{};          ///< of the [camera.video.board] table
};

struct VideoConfig {
  std::string rig_path;
  std::string camera;  ///< the [[camera]]'s name
  std::vector<VideoLed> leds;
  /// The camera's true frame rate, Hz: stamps the frames of a file (its
  /// container's rate then only numbers them: a slow-motion export) and
  /// times an image sequence; absent: the container's rate.
  std::optional<double> fps;
  int fps_line{};
  /// Exposure time, s: a frame's time is the middle of its exposure (the
  /// container's time taken as its start). 0: times as stored.
  double exposure_s{0};
  /// Rolling shutter: row r starts its exposure readout_s x r / height
  /// after row 0, s; each LED is taken back to row 0's time. 0: global shutter.
  double readout_s{0};
  /// No LED identified for longer than this is an error (the read stops,
  /// naming the file and frame), s; 0: never an error.
  double max_dark_s{1.0};
  /// Region searched for LEDs: x, y, width, height (px); width 0 = whole frame.
  std::array<int, 4> roi_px{};
  ColourChoice colour;         ///< `channel`: the light the LEDs are found in
  double threshold{40};        ///< 8-bit level a blob's pixels exceed
  int min_area_px{2};          ///< smaller blobs are noise
  int max_area_px{2000};       ///< larger ones are not one LED (merged, a reflection)
  double saturation{255};      ///< 8-bit level at which a pixel is clipped
  double gate_m{};             ///< identification radius around a prediction, m; 0 = 0.4 x smallest LED spacing
  double residual_m{0.003};    ///< an identified LED further than this from the rigid fit is dropped, m
  std::optional<Intrinsics> intrinsics;  ///< absent: an ideal lens (no undistortion)
  std::vector<Mark> marks;     ///< >= 4: image-to-plane homography (none with a board)
  BoardConfig board;           ///< present: the marks come from the board (ResolveBoardMarks)
  SyncLedConfig sync;          ///< absent (present false): no sync source
};

/// The one camera of `rig` that has a `[camera.video]` section.
/// @throws std::runtime_error "PATH:LINE: key 'camera.video.K' ..." on a
///         missing, mistyped, unknown or out-of-range key, fewer than 4
///         marks (and no board), a board with marks, an LED without its channels, or no (or more than one)
///         camera with a video section.
VideoConfig LoadVideoConfig(const daq::RigConfig& rig);

/// OpenCV's value of a predefined ArUco dictionary's name ("DICT_4X4_50"
/// is 0), -1 for a name it does not have.
int BoardDictionaryIndex(const std::string& name);

/// Reads an intrinsics file as `rocklab camera-calibrate` writes it.
/// @throws std::runtime_error naming the file, line and key.
Intrinsics LoadIntrinsics(const std::string& path);
/// Writes one (beside, then renamed: whole or not at all): `# comment`,
/// then `comment_lines` as they are (whole `#` lines: the provenance).
/// @throws std::runtime_error naming the file.
void WriteIntrinsics(const std::string& path, const Intrinsics& k, const std::string& comment,
                     const std::string& comment_lines = {});

}  // namespace rocklab::video
