#include "video/video_config.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <set>
#include <sstream>
#include <stdexcept>

#include <toml++/toml.h>

namespace rocklab::video {
namespace {

// Keys of one table, read with the file, line and key in every error;
// Done() rejects the keys nobody read (a typo is never ignored).
class Keys {
 public:
  Keys(const std::string& path, const toml::table& table, std::string prefix)
      : path_(path), table_(table), prefix_(std::move(prefix)) {}

  [[noreturn]] void Fail(int line, const std::string& key, const std::string& what) const {
    std::ostringstream msg;
    msg << path_ << ":" << line << ": key '" << Join(key) << "' " << what;
    throw std::runtime_error(msg.str());
  }
  static int LineOf(const toml::node& n) { return static_cast<int>(n.source().begin.line); }
  int line() const { return LineOf(table_); }
  int LineOfKey(const std::string& key) const {
    const toml::node* n = table_.get(key);
    return n != nullptr ? LineOf(*n) : line();
  }

  const toml::node* Get(const std::string& key) {
    seen_.insert(key);
    return table_.get(key);
  }
  std::optional<double> Number(const std::string& key, double lo, double hi) {
    const toml::node* n = Get(key);
    if (n == nullptr) return std::nullopt;
    const std::optional<double> v = n->value<double>();
    if (!v || !std::isfinite(*v)) Fail(LineOf(*n), key, "must be a number");
    if (*v < lo || *v > hi) {
      Fail(LineOf(*n), key, "must be in [" + Str(lo) + ", " + Str(hi) + "] (is " + Str(*v) + ")");
    }
    return v;
  }
  double Required(const std::string& key, double lo, double hi) {
    const std::optional<double> v = Number(key, lo, hi);
    if (!v) Fail(line(), key, "is missing");
    return *v;
  }
  void Done() const {
    for (const auto& [k, v] : table_) {
      if (seen_.count(std::string(k.str())) == 0) Fail(LineOf(v), std::string(k.str()), "is not a video key");
    }
  }
  std::string Join(const std::string& key) const { return prefix_.empty() ? key : prefix_ + "." + key; }

 private:
  static std::string Str(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
  }
  const std::string& path_;
  const toml::table& table_;
  std::string prefix_;
  std::set<std::string> seen_;
};

constexpr double kMaxPx = 100000;
constexpr double kMaxLengthM = 100;

Intrinsics ParseIntrinsics(const std::string& path, const toml::table& t, const std::string& prefix) {
  Keys k(path, t, prefix);
  Intrinsics in;
  in.fx_px = k.Required("fx_px", 1e-3, 1e7);
  in.fy_px = k.Required("fy_px", 1e-3, 1e7);
  in.cx_px = k.Required("cx_px", -kMaxPx, kMaxPx);
  in.cy_px = k.Required("cy_px", -kMaxPx, kMaxPx);
  in.width_px = static_cast<int>(k.Number("width_px", 0, kMaxPx).value_or(0));
  in.height_px = static_cast<int>(k.Number("height_px", 0, kMaxPx).value_or(0));
  in.rms_reprojection_px = k.Number("rms_reprojection_px", 0, kMaxPx).value_or(-1);
  in.views = static_cast<int>(k.Number("views", 0, 1e6).value_or(0));
  if (const toml::node* d = k.Get("distortion")) {
    const toml::array* a = d->as_array();
    if (a == nullptr || a->size() != 5) {
      k.Fail(Keys::LineOf(*d), "distortion", "must be [k1, k2, p1, p2, k3]");
    }
    for (std::size_t i = 0; i < 5; ++i) {
      const std::optional<double> v = a->get(i)->value<double>();
      if (!v || !std::isfinite(*v) || std::abs(*v) > 1e3) {
        k.Fail(Keys::LineOf(*d), "distortion", "must hold 5 finite numbers of at most 1000");
      }
      in.distortion[i] = *v;
    }
  }
  k.Done();
  return in;
}

std::string Slurp(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::runtime_error(path + ": cannot be read");
  std::string text;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  std::fclose(f);
  return text;
}

toml::table ParseFile(const std::string& path) {
  const std::string text = Slurp(path);
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << path << ":" << e.source().begin.line << ": " << e.description();
    throw std::runtime_error(msg.str());
  }
}

// OpenCV's predefined ArUco dictionaries, in the order of its
// PREDEFINED_DICTIONARY_NAME (the index is the enum's value).
constexpr const char* kBoardDictionaries[] = {
    "DICT_4X4_50",   "DICT_4X4_100",   "DICT_4X4_250",      "DICT_4X4_1000",      "DICT_5X5_50",
    "DICT_5X5_100",  "DICT_5X5_250",   "DICT_5X5_1000",     "DICT_6X6_50",        "DICT_6X6_100",
    "DICT_6X6_250",  "DICT_6X6_1000",  "DICT_7X7_50",       "DICT_7X7_100",       "DICT_7X7_250",
    "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
    "DICT_APRILTAG_36h11"};

bool IsBoardDictionary(const std::string& name) { return BoardDictionaryIndex(name) >= 0; }

std::string BoardDictionaryNames() {
  std::string all;
  for (const char* n : kBoardDictionaries) all += (all.empty() ? "" : ", ") + std::string(n);
  return all;
}

// A board's table: its layout as printed, where it hangs, where it is seen.
BoardConfig ParseBoard(const std::string& path, const toml::table& t) {
  Keys k(path, t, "camera.video.board");
  BoardConfig b;
  b.present = true;
  b.line = Keys::LineOf(t);
  const toml::node* kind = k.Get("kind");
  const std::optional<std::string> kind_name = kind != nullptr ? kind->value<std::string>() : std::nullopt;
  if (kind != nullptr && (!kind_name || *kind_name != "charuco")) {
    k.Fail(Keys::LineOf(*kind), "kind", "must be \"charuco\" (a chessboard with ArUco markers in its white squares)");
  }
  if (const toml::node* d = k.Get("dictionary")) {
    const std::optional<std::string> name = d->value<std::string>();
    if (!name || !IsBoardDictionary(*name)) {
      k.Fail(Keys::LineOf(*d), "dictionary", "must name one of OpenCV's predefined ArUco dictionaries (" +
                                                 BoardDictionaryNames() + ")");
    }
    b.dictionary = *name;
  }
  const toml::node* sq = k.Get("squares");
  const toml::array* sa = sq != nullptr ? sq->as_array() : nullptr;
  std::optional<int64_t> sx, sy;
  if (sa != nullptr && sa->size() == 2) sx = sa->get(0)->value<int64_t>(), sy = sa->get(1)->value<int64_t>();
  if (!sx || !sy || *sx < 2 || *sy < 2 || *sx > 100 || *sy > 100 || *sx * *sy < 6) {
    k.Fail(sq != nullptr ? Keys::LineOf(*sq) : k.line(), "squares",
           "must be [across, down]: the board's squares, 2 to 100 each (at least 3 inner corners)");
  }
  b.squares_x = static_cast<int>(*sx);
  b.squares_y = static_cast<int>(*sy);
  b.square_m = k.Required("square_m", 1e-4, kMaxLengthM);
  b.marker_m = k.Required("marker_m", 1e-4, kMaxLengthM);
  if (b.marker_m >= b.square_m) k.Fail(k.LineOfKey("marker_m"), "marker_m", "must be smaller than square_m");
  const toml::node* o = k.Get("origin_m");
  const toml::array* oa = o != nullptr ? o->as_array() : nullptr;
  std::optional<double> ox, oz;
  if (oa != nullptr && oa->size() == 2) ox = oa->get(0)->value<double>(), oz = oa->get(1)->value<double>();
  if (!ox || !oz || !std::isfinite(*ox) || !std::isfinite(*oz) || std::abs(*ox) > kMaxLengthM ||
      std::abs(*oz) > kMaxLengthM) {
    k.Fail(o != nullptr ? Keys::LineOf(*o) : k.line(), "origin_m",
           "must be [x, z]: the rig coordinates of the board's top-left corner, m");
  }
  b.origin_x_m = *ox;
  b.origin_z_m = *oz;
  if (const toml::node* im = k.Get("image")) {
    const std::optional<std::string> file = im->value<std::string>();
    if (!file || file->empty()) k.Fail(Keys::LineOf(*im), "image", "must be a file name (an image or a video)");
    b.image = (std::filesystem::path(path).parent_path() / *file).string();
  }
  b.min_corners = static_cast<int>(k.Number("min_corners", 4, 1e6).value_or(b.min_corners));
  k.Done();
  return b;
}

}  // namespace

std::string ColourChoice::Describe() const {
  if (kind == Kind::kGrey) return "grey";
  if (kind == Kind::kChannel) return channel == 0 ? "red" : channel == 1 ? "green" : "blue";
  char b[96];
  std::snprintf(b, sizeof b, "%g R + %g G + %g B", rgb[0], rgb[1], rgb[2]);
  return b;
}

Intrinsics LoadIntrinsics(const std::string& path) {
  const toml::table root = ParseFile(path);
  return ParseIntrinsics(path, root, "");
}

void WriteIntrinsics(const std::string& path, const Intrinsics& k, const std::string& comment,
                     const std::string& comment_lines) {
  const std::string part = path + ".part";
  std::FILE* f = std::fopen(part.c_str(), "w");
  if (f == nullptr) throw std::runtime_error("cannot write '" + part + "'");
  std::fprintf(f, "# %s\n%s", comment.c_str(), comment_lines.c_str());
  std::fprintf(f, "width_px = %d\nheight_px = %d\n", k.width_px, k.height_px);
  std::fprintf(f, "fx_px = %.10g\nfy_px = %.10g\ncx_px = %.10g\ncy_px = %.10g\n", k.fx_px, k.fy_px,
               k.cx_px, k.cy_px);
  std::fprintf(f, "distortion = [%.10g, %.10g, %.10g, %.10g, %.10g]  # k1, k2, p1, p2, k3\n",
               k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3], k.distortion[4]);
  std::fprintf(f, "rms_reprojection_px = %.6g\nviews = %d\n", k.rms_reprojection_px, k.views);
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) {
    std::remove(part.c_str());
    throw std::runtime_error("cannot write '" + part + "'");
  }
  std::filesystem::rename(part, path);
}

int BoardDictionaryIndex(const std::string& name) {
  for (std::size_t i = 0; i < std::size(kBoardDictionaries); ++i) {
    if (name == kBoardDictionaries[i]) return static_cast<int>(i);
  }
  return -1;
}

VideoConfig LoadVideoConfig(const daq::RigConfig& rig) {
  const toml::table root = ParseFile(rig.path);
  const toml::array* cams = root["camera"].as_array();
  const toml::table* video = nullptr;
  const daq::CameraConfig* camera = nullptr;
  if (cams != nullptr) {
    for (std::size_t i = 0; i < cams->size() && i < rig.cameras.size(); ++i) {
      const toml::table* t = cams->get(i)->as_table();
      const toml::node* v = t != nullptr ? t->get("video") : nullptr;
      if (v == nullptr) continue;
      if (v->as_table() == nullptr) {
        throw std::runtime_error(rig.path + ":" + std::to_string(Keys::LineOf(*v)) +
                                 ": key 'camera.video' must be a table ([camera.video])");
      }
      if (video != nullptr) {
        throw std::runtime_error(rig.path + ":" + std::to_string(Keys::LineOf(*v)) +
                                 ": key 'camera.video': a second camera with video (one video input "
                                 "reads one camera)");
      }
      video = v->as_table();
      camera = &rig.cameras[i];
    }
  }
  if (video == nullptr) {
    throw std::runtime_error(rig.path + ": no [camera.video] section (a video input needs one: docs/video.md)");
  }

  VideoConfig c;
  c.rig_path = rig.path;
  c.camera = camera->name;
  for (const daq::LedConfig& led : camera->leds) {
    VideoLed v{led.name, led.x_m, led.z_m, rig.FindSensor(camera->name + "." + led.name + ".x"),
               rig.FindSensor(camera->name + "." + led.name + ".z")};
    if (v.x_channel == nullptr || v.z_channel == nullptr) {
      throw std::runtime_error(rig.path + ":" + std::to_string(Keys::LineOf(*video)) + ": camera '" +
                               camera->name + "' LED '" + led.name + "' needs channels with sensor " +
                               camera->name + "." + led.name + ".x and .z for its video");
    }
    if (v.x_channel->gain == 0 || v.z_channel->gain == 0) {
      throw std::runtime_error(rig.path + ":" + std::to_string(v.x_channel->line) + ": key 'channel.gain' of " +
                               camera->name + "." + led.name + " must not be 0 for a video input");
    }
    c.leds.push_back(v);
  }

  Keys k(rig.path, *video, "camera.video");
  if ((c.fps = k.Number("fps", 0.01, 1e6))) c.fps_line = k.LineOfKey("fps");
  c.exposure_s = k.Number("exposure_s", 0, 10).value_or(c.exposure_s);
  c.readout_s = k.Number("readout_s", 0, 10).value_or(c.readout_s);
  c.max_dark_s = k.Number("max_dark_s", 0, 1e9).value_or(c.max_dark_s);
  if (const toml::node* n = k.Get("roi_px")) {
    const toml::array* a = n->as_array();
    bool ok = a != nullptr && a->size() == 4;
    for (std::size_t i = 0; ok && i < 4; ++i) {
      const std::optional<int64_t> v = a->get(i)->value<int64_t>();
      ok = v && *v >= 0 && *v <= kMaxPx;
      if (ok) c.roi_px[i] = static_cast<int>(*v);
    }
    if (!ok) k.Fail(Keys::LineOf(*n), "roi_px", "must be [x, y, width, height], whole pixels >= 0");
  }
  if (const toml::node* n = k.Get("channel")) {
    if (const std::optional<std::string> name = n->value<std::string>()) {
      const char* const kNames[] = {"red", "green", "blue"};
      c.colour.kind = ColourChoice::Kind::kChannel;
      c.colour.channel = -1;
      for (int i = 0; i < 3; ++i) c.colour.channel = *name == kNames[i] ? i : c.colour.channel;
      if (*name == "grey" || *name == "gray") c.colour.kind = ColourChoice::Kind::kGrey;
      if (c.colour.kind == ColourChoice::Kind::kChannel && c.colour.channel < 0) {
        k.Fail(Keys::LineOf(*n), "channel", "must be \"red\", \"green\", \"blue\", \"grey\" or [r, g, b] weights (is \"" +
                                                *name + "\")");
      }
    } else {
      const toml::array* a = n->as_array();
      bool ok = a != nullptr && a->size() == 3;
      double sum = 0;
      for (std::size_t i = 0; ok && i < 3; ++i) {
        const std::optional<double> v = a->get(i)->value<double>();
        ok = v && std::isfinite(*v) && std::abs(*v) <= 10;
        if (ok) sum += std::abs(c.colour.rgb[i] = *v);
      }
      if (!ok || sum == 0) {
        k.Fail(Keys::LineOf(*n), "channel", "must be a name or [r, g, b]: three weights of at most 10, not all 0");
      }
      c.colour.kind = ColourChoice::Kind::kWeights;
    }
  }
  c.threshold = k.Number("threshold", 1, 254).value_or(c.threshold);
  c.min_area_px = static_cast<int>(k.Number("min_area_px", 1, 1e6).value_or(c.min_area_px));
  c.max_area_px = static_cast<int>(k.Number("max_area_px", 1, 1e7).value_or(c.max_area_px));
  if (c.max_area_px < c.min_area_px) k.Fail(k.LineOfKey("max_area_px"), "max_area_px", "must be >= min_area_px");
  c.saturation = k.Number("saturation", 2, 255).value_or(c.saturation);
  c.gate_m = k.Number("gate_m", 1e-6, kMaxLengthM).value_or(0);
  c.residual_m = k.Number("residual_m", 1e-6, kMaxLengthM).value_or(c.residual_m);
  if (const toml::node* n = k.Get("intrinsics")) {
    if (const std::optional<std::string> file = n->value<std::string>()) {
      // Relative to the rig file.
      const std::filesystem::path p = std::filesystem::path(rig.path).parent_path() / *file;
      c.intrinsics = LoadIntrinsics(p.string());
    } else if (const toml::table* t = n->as_table()) {
      c.intrinsics = ParseIntrinsics(rig.path, *t, "camera.video.intrinsics");
    } else {
      k.Fail(Keys::LineOf(*n), "intrinsics", "must be a file name (rocklab camera-calibrate's) or a table");
    }
  }
  const toml::node* marks = k.Get("mark");
  const toml::array* ma = marks != nullptr ? marks->as_array() : nullptr;
  if (const toml::node* b = k.Get("board")) {
    const toml::table* t = b->as_table();
    if (t == nullptr) k.Fail(Keys::LineOf(*b), "board", "must be a table ([camera.video.board])");
    if (marks != nullptr) {
      k.Fail(Keys::LineOf(*marks), "mark", "and [camera.video.board] both give the marks: keep one");
    }
    c.board = ParseBoard(rig.path, *t);
  } else if (ma == nullptr || ma->size() < 4) {
    k.Fail(marks != nullptr ? Keys::LineOf(*marks) : k.line(), "mark",
           "must list at least 4 reference marks { u_px, v_px, x_m, z_m } (image to rig plane)");
  }
  for (std::size_t i = 0; ma != nullptr && i < ma->size(); ++i) {
    const toml::node& node = *ma->get(i);
    const toml::table* t = node.as_table();
    if (t == nullptr) k.Fail(Keys::LineOf(node), "mark", "must be tables { u_px, v_px, x_m, z_m }");
    Keys mk(rig.path, *t, "camera.video.mark");
    Mark m;
    m.u_px = mk.Required("u_px", -kMaxPx, kMaxPx);
    m.v_px = mk.Required("v_px", -kMaxPx, kMaxPx);
    m.x_m = mk.Required("x_m", -kMaxLengthM, kMaxLengthM);
    m.z_m = mk.Required("z_m", -kMaxLengthM, kMaxLengthM);
    m.line = Keys::LineOf(node);
    mk.Done();
    c.marks.push_back(m);
  }
  if (const toml::node* n = k.Get("sync")) {
    const std::optional<std::string> how = n->value<std::string>();
    if (!how || (*how != "led" && *how != "table")) {
      k.Fail(Keys::LineOf(*n), "sync", "must be \"led\" (a sync LED driven by a DAQ channel) or \"table\" (the "
                                       "table's motion against its displacement channel): docs/video.md");
    }
    c.sync.present = true;
    c.sync.line = Keys::LineOf(*n);
    if (*how == "table") {
      c.sync.by_table = true;
      if (const toml::node* led = k.Get("sync_led_px")) {
        k.Fail(Keys::LineOf(*led), "sync_led_px", "is for sync = \"led\" (sync = \"table\" needs no LED)");
      }
      const toml::node* ch = k.Get("sync_channel");
      const std::optional<std::string> name = ch != nullptr ? ch->value<std::string>() : std::nullopt;
      if (!name || name->empty()) {
        k.Fail(ch != nullptr ? Keys::LineOf(*ch) : c.sync.line, "sync_channel",
               "must name the DAQ file's column of the table's displacement");
      }
      c.sync.channel = *name;
    } else {
      const toml::node* at = k.Get("sync_led_px");
      const toml::array* a = at != nullptr ? at->as_array() : nullptr;
      std::optional<double> u, v;
      if (a != nullptr && a->size() == 2) u = a->get(0)->value<double>(), v = a->get(1)->value<double>();
      if (!u || !v || *u < 0 || *v < 0 || *u > kMaxPx || *v > kMaxPx) {
        k.Fail(at != nullptr ? Keys::LineOf(*at) : c.sync.line, "sync_led_px",
               "must be [u, v]: the sync LED's column and row in the image, px >= 0");
      }
      c.sync.u_px = *u;
      c.sync.v_px = *v;
      c.sync.radius_px = static_cast<int>(k.Number("sync_radius_px", 0, 100).value_or(c.sync.radius_px));
      const toml::node* ch = k.Get("sync_channel");
      const std::optional<std::string> name = ch != nullptr ? ch->value<std::string>() : std::nullopt;
      if (!name || name->empty()) {
        k.Fail(ch != nullptr ? Keys::LineOf(*ch) : c.sync.line, "sync_channel",
               "must name the DAQ file's column that drives the sync LED");
      }
      c.sync.channel = *name;
    }
  } else if (k.Get("sync_led_px") != nullptr || k.Get("sync_channel") != nullptr ||
             k.Get("sync_radius_px") != nullptr) {
    k.Fail(k.LineOfKey("sync_led_px"), "sync", "is missing (sync_led_px, sync_channel need sync = \"led\")");
  }
  k.Done();
  return c;
}

}  // namespace rocklab::video
