// Fuzz target: a rig file's [camera.video] section (docs/video.md) through
// daq::ParseRigConfig, video::LoadVideoConfig and the image-to-plane map the
// marks define (video::PlaneMap). Input: the rig file's bytes, written to a
// scratch file of this process (the video section is read from the file).
// Invariants: only std::runtime_error escapes, its message one bounded line
// of printable ASCII naming the file; an accepted section has its values
// within the documented bounds, at least 4 marks (or a board, whose marks
// are found later in its image) and one LED with channels,
// and a PlaneMap built from it maps its marks to finite points.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "daq/rig_config.h"
#include "tests/fuzz/fuzz_util.h"
#include "video/plane_map.h"
#include "video/video_config.h"

namespace {

void CheckError(const std::string& path, const std::runtime_error& e) {
  const std::string message = e.what();
  if (message.rfind(path, 0) != 0) rocklab::fuzz::Violated("message without the file", message);
  rocklab::fuzz::CheckMessage(message, 1024);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rocklab::fuzz::WriteScratch("rig_video.toml", data, size);
  const std::string text(reinterpret_cast<const char*>(data), size);
  rocklab::daq::RigConfig rig;
  try {
    rig = rocklab::daq::ParseRigConfig(text, path);
  } catch (const std::runtime_error& e) {
    CheckError(path, e);
    return 0;
  }
  rocklab::video::VideoConfig c;
  try {
    c = rocklab::video::LoadVideoConfig(rig);
  } catch (const std::runtime_error& e) {
    CheckError(path, e);
    return 0;
  }
  // A board's marks are found in its image when the input opens, not here.
  if (c.leds.empty() || (c.marks.size() < 4 && !c.board.present)) {
    rocklab::fuzz::Violated("accepted without LEDs or 4 marks (or a board)");
  }
  if (c.board.present && (!c.marks.empty() || c.board.squares_x < 2 || c.board.squares_y < 2 ||
                          !(c.board.marker_m < c.board.square_m))) {
    rocklab::fuzz::Violated("a board with typed marks or an impossible layout");
  }
  if (c.board.present) return 0;
  for (const auto& led : c.leds) {
    if (led.x_channel == nullptr || led.z_channel == nullptr) rocklab::fuzz::Violated("an LED without channels");
  }
  if (c.fps && !(*c.fps >= 0.01 && *c.fps <= 1e6)) rocklab::fuzz::Violated("fps out of its bounds");
  if (c.min_area_px < 1 || c.max_area_px < c.min_area_px) rocklab::fuzz::Violated("blob areas out of order");
  if (!(c.threshold >= 1 && c.threshold <= 254)) rocklab::fuzz::Violated("threshold out of its bounds");
  for (int v : c.roi_px) {
    if (v < 0) rocklab::fuzz::Violated("a negative roi");
  }
  try {
    const rocklab::video::PlaneMap map(c.intrinsics, c.marks, c.rig_path);
    std::vector<cv::Point2d> image, plane;
    for (const auto& m : c.marks) image.emplace_back(m.u_px, m.v_px);
    map.ToPlane(image, plane);
    if (plane.size() != image.size()) rocklab::fuzz::Violated("ToPlane lost points");
  } catch (const std::runtime_error& e) {
    CheckError(path, e);
  }
  return 0;
}
