#include "model/block.h"

#include "common/cancel.h"
#include "common/text.h"
#include "model/numbers.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

namespace rocklab::model {
namespace {

using detail::ExactText;
using detail::kPi;

[[noreturn]] void Bad(const std::string& what, const std::string& rule, double value) {
  throw std::invalid_argument(what + " must be " + rule + " (got " + ExactText(value) + ")");
}

}  // namespace

void BlockParams::Validate() const {
  auto side = [](const std::string& prefix, double a, double freq, double m) {
    if (!std::isfinite(a) || a <= 0.0 || a >= kPi / 2) Bad(prefix + "alpha", "in (0, pi/2) rad", a);
    if (!std::isfinite(freq) || freq <= 0.0) Bad(prefix + "p", "finite and > 0 rad/s", freq);
    if (!std::isfinite(m) || m <= 0.0 || m > 1.0) Bad(prefix + "mu", "in (0, 1]", m);
  };
  side("", alpha, p, mu);
  if (minus) side("minus.", minus->alpha, minus->p, minus->mu);
}

BlockParams BlockGeometry::params() const {
  BlockParams out{alpha, p, mu_general};
  if (!symmetric) out.minus = SideParams{minus.alpha, minus.p, minus.mu};
  return out;
}

BlockGeometry RectangleBlock(double width_m, double height_m, double chamfer_m, double g) {
  if (!std::isfinite(width_m) || width_m <= 0.0) Bad("width_m", "finite and > 0 m", width_m);
  if (!std::isfinite(height_m) || height_m <= 0.0) Bad("height_m", "finite and > 0 m", height_m);
  const double b = width_m / 2;
  const double h = height_m / 2;
  if (!std::isfinite(chamfer_m) || chamfer_m < 0.0 || chamfer_m >= std::min(b, h)) {
    Bad("chamfer_m", "in [0, min(b, h)) m", chamfer_m);
  }
  if (!std::isfinite(g) || g <= 0.0) Bad("g", "finite and > 0 m/s^2", g);
  // Base on y = 0, symmetric about x = 0, counter-clockwise.
  std::vector<Eigen::Vector2d> v;
  if (chamfer_m > 0.0) {
    const double c = chamfer_m;
    v = {{-b + c, 0.0}, {b - c, 0.0}, {b, c}, {b, 2 * h}, {-b, 2 * h}, {-b, c}};
  } else {
    v = {{-b, 0.0}, {b, 0.0}, {b, 2 * h}, {-b, 2 * h}};
  }
  return PolygonBlock(v, g);
}

namespace {

// Sign of the turn a -> b -> c with a tolerance `eps` (m^2).
int Orientation(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, double eps) {
  const double cross = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  return cross > eps ? 1 : (cross < -eps ? -1 : 0);
}

// c on the segment [a, b], given a, b, c collinear.
bool OnSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, double eps) {
  return c.x() <= std::max(a.x(), b.x()) + eps && c.x() >= std::min(a.x(), b.x()) - eps &&
         c.y() <= std::max(a.y(), b.y()) + eps && c.y() >= std::min(a.y(), b.y()) - eps;
}

bool SegmentsTouch(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2, const Eigen::Vector2d& q1,
                   const Eigen::Vector2d& q2, double eps_area, double eps_len) {
  const int o1 = Orientation(p1, p2, q1, eps_area);
  const int o2 = Orientation(p1, p2, q2, eps_area);
  const int o3 = Orientation(q1, q2, p1, eps_area);
  const int o4 = Orientation(q1, q2, p2, eps_area);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && OnSegment(p1, p2, q1, eps_len)) || (o2 == 0 && OnSegment(p1, p2, q2, eps_len)) ||
         (o3 == 0 && OnSegment(q1, q2, p1, eps_len)) || (o4 == 0 && OnSegment(q1, q2, p2, eps_len));
}

double Scale(const std::vector<Eigen::Vector2d>& v) {
  double scale = 0.0;
  for (const auto& x : v) scale = std::max(scale, x.cwiseAbs().maxCoeff());
  return std::max(scale, 1e-300);
}

}  // namespace

namespace {

// An edge for the sweep: its end with the smaller (x, z) first.
struct SweepEdge {
  Eigen::Vector2d l, r;
};

bool LexLess(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
}

// Exact side of p from the line l -> r: +1 left (above), -1 right, 0 on it.
int Side(const Eigen::Vector2d& l, const Eigen::Vector2d& r, const Eigen::Vector2d& p) {
  const double cross = (r - l).x() * (p - l).y() - (r - l).y() * (p - l).x();
  return cross > 0 ? 1 : (cross < 0 ? -1 : 0);
}

// Order of the edges the sweep line crosses, bottom to top. Edges that do
// not cross keep one order while both are crossed; for a = edges[i] whose
// left end comes first, i is below j when j's left end (or, on i's line,
// its right end) is above i's line. Collinear edges: by index.
struct SweepBelow {
  const std::vector<SweepEdge>* edges;
  bool operator()(std::size_t i, std::size_t j) const {
    if (i == j) return false;
    const SweepEdge& a = (*edges)[i];
    const SweepEdge& b = (*edges)[j];
    if (LexLess(b.l, a.l)) return Above(j, b, i, a);
    return !Above(i, a, j, b);
  }
  // Whether edge i (left end first) is above edge j.
  static bool Above(std::size_t i, const SweepEdge& a, std::size_t j, const SweepEdge& b) {
    int side = Side(a.l, a.r, b.l);
    if (side == 0) side = Side(a.l, a.r, b.r);
    return side == 0 ? i > j : side < 0;
  }
};

}  // namespace

// Shamos and Hoey's sweep (1976): edges enter and leave an ordered set at
// their ends, taken in (x, z) order; two edges that touch or cross are next
// to each other in the set before the sweep passes the first such point,
// so only neighbours in the set are tested: at most 3n tests and
// O(n log n) time, where testing every pair took n^2/2 (a 100 000-vertex
// section took 39 s).
std::optional<std::pair<std::size_t, std::size_t>> FindCrossingEdges(const std::vector<Eigen::Vector2d>& v,
                                                                     std::size_t* pair_tests) {
  const std::size_t n = v.size();
  if (pair_tests != nullptr) *pair_tests = 0;
  if (n < 4) return std::nullopt;  // a triangle's edges are all neighbours
  const double scale = Scale(v);
  std::vector<SweepEdge> edges(n);
  struct Event {
    Eigen::Vector2d at;
    bool leaves;
    std::size_t edge;
  };
  std::vector<Event> events;
  events.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = v[i];
    const Eigen::Vector2d& q = v[(i + 1) % n];
    edges[i] = LexLess(q, p) ? SweepEdge{q, p} : SweepEdge{p, q};
    events.push_back({edges[i].l, false, i});
    events.push_back({edges[i].r, true, i});
  }
  // At one point, edges enter before others leave: edges that meet end to
  // end are then tested.
  std::sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    if (a.at != b.at) return LexLess(a.at, b.at);
    if (a.leaves != b.leaves) return !a.leaves;
    return a.edge < b.edge;
  });
  const auto neighbours = [n](std::size_t i, std::size_t j) {
    const std::size_t d = i > j ? i - j : j - i;
    return d == 1 || d == n - 1;
  };
  std::optional<std::pair<std::size_t, std::size_t>> found;
  // A vertex where the outline turns back on itself (its two edges
  // collinear and overlapping: a spike of no width): those two edges touch
  // beyond their vertex. Found here, because the overlap would also hide
  // other edges that touch there from the sweep.
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d back = v[(k + n - 1) % n] - v[k];
    const Eigen::Vector2d ahead = v[(k + 1) % n] - v[k];
    if (std::abs(back.x() * ahead.y() - back.y() * ahead.x()) <= 1e-12 * scale * scale && back.dot(ahead) > 0) {
      return std::make_pair(k == 0 ? std::size_t{0} : k - 1, k == 0 ? n - 1 : k);
    }
  }
  // Edges that end at one point: two of them that are not neighbours touch
  // there (a vertex repeated out of turn). Checked here, because between
  // them in the order may lie an edge that neighbours both, whose tests
  // are skipped (a polygon that comes back to a vertex from both sides).
  for (std::size_t a = 0, b = 0; a < events.size(); a = b) {
    while (b < events.size() && events[b].at == events[a].at) ++b;
    for (std::size_t i = a; i < b && !found; ++i) {
      for (std::size_t j = i + 1; j < b && !found; ++j) {
        if (!neighbours(events[i].edge, events[j].edge)) {
          found = std::make_pair(std::min(events[i].edge, events[j].edge), std::max(events[i].edge, events[j].edge));
        }
      }
    }
    if (found) return found;
  }
  const auto test = [&](std::size_t i, std::size_t j) {
    if (found || neighbours(i, j)) return;
    if (pair_tests != nullptr) ++*pair_tests;
    if (SegmentsTouch(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n], 1e-12 * scale * scale, 1e-12 * scale)) {
      found = std::make_pair(std::min(i, j), std::max(i, j));
    }
  };
  using Active = std::set<std::size_t, SweepBelow>;
  Active active(SweepBelow{&edges});
  std::vector<Active::iterator> where(n, active.end());
  for (const Event& e : events) {
    if (!e.leaves) {
      const auto it = active.insert(e.edge).first;  // never equal: ties go by index
      where[e.edge] = it;
      if (it != active.begin()) test(*std::prev(it), e.edge);
      if (std::next(it) != active.end()) test(e.edge, *std::next(it));
    } else {
      const auto it = where[e.edge];
      if (it != active.begin() && std::next(it) != active.end()) test(*std::prev(it), *std::next(it));
      active.erase(it);
    }
    if (found) return found;
  }
  return std::nullopt;
}

BlockGeometry PolygonBlock(const std::vector<Eigen::Vector2d>& vertices_in, double g) {
  std::vector<Eigen::Vector2d> vertices_m = vertices_in;
  if (vertices_m.size() > 3 && vertices_m.front() == vertices_m.back()) vertices_m.pop_back();
  const std::size_t n = vertices_m.size();
  if (n < 3) {
    throw std::invalid_argument("vertices_m must hold at least 3 vertices (got " +
                                std::to_string(n) + ")");
  }
  if (!std::isfinite(g) || g <= 0.0) Bad("g", "finite and > 0 m/s^2", g);
  for (std::size_t i = 0; i < n; ++i) {
    if (!vertices_m[i].allFinite()) {
      throw std::invalid_argument("vertices_m[" + std::to_string(i) + "] is not finite");
    }
  }
  const double scale = Scale(vertices_m);
  const double tie = 1e-12 * std::max(scale, 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    if ((vertices_m[i] - vertices_m[(i + 1) % n]).cwiseAbs().maxCoeff() <= tie) {
      throw std::invalid_argument("vertices_m[" + std::to_string((i + 1) % n) + "] repeats vertices_m[" +
                                  std::to_string(i) + "]");
    }
  }
  // Shoelace sums with the first vertex as origin: area, first and polar
  // second moments of area.
  const Eigen::Vector2d origin = vertices_m[0];
  double a2 = 0.0;   // 2 * signed area
  double sx6 = 0.0;  // 6 * signed first moment about the z axis (x centroid * area)
  double sy6 = 0.0;
  double j12 = 0.0;  // 12 * signed polar moment about the origin
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p0 = vertices_m[i] - origin;
    const Eigen::Vector2d p1 = vertices_m[(i + 1) % n] - origin;
    const double cross = p0.x() * p1.y() - p1.x() * p0.y();
    a2 += cross;
    sx6 += (p0.x() + p1.x()) * cross;
    sy6 += (p0.y() + p1.y()) * cross;
    j12 += cross * (p0.x() * p0.x() + p0.x() * p1.x() + p1.x() * p1.x() + p0.y() * p0.y() +
                    p0.y() * p1.y() + p1.y() * p1.y());
  }
  const double area = std::abs(a2) / 2;
  if (const auto crossing = FindCrossingEdges(vertices_m)) {
    throw std::invalid_argument("vertices_m: edges " + std::to_string(crossing->first) + "-" +
                                std::to_string((crossing->first + 1) % n) + " and " +
                                std::to_string(crossing->second) + "-" +
                                std::to_string((crossing->second + 1) % n) +
                                " touch or cross: not a simple polygon");
  }
  if (!(area > 1e-12 * scale * scale)) {
    throw std::invalid_argument("vertices_m: polygon has zero area");
  }
  const Eigen::Vector2d centroid = origin + Eigen::Vector2d(sx6 / (3 * a2), sy6 / (3 * a2));
  const double i_origin_per_area = (j12 / 12) / (a2 / 2);
  const double i_g_per_area = i_origin_per_area - (centroid - origin).squaredNorm();

  // Pivots: the lowest vertices with the largest and the smallest x.
  double y_min = vertices_m[0].y();
  for (const auto& v : vertices_m) y_min = std::min(y_min, v.y());
  Eigen::Vector2d plus(-HUGE_VAL, y_min);
  Eigen::Vector2d minus(HUGE_VAL, y_min);
  for (const auto& v : vertices_m) {
    if (v.y() > y_min + tie) continue;
    if (v.x() > plus.x()) plus = v;
    if (v.x() < minus.x()) minus = v;
  }
  if (!(plus.x() - minus.x() > tie)) {
    throw std::invalid_argument("vertices_m: the section rests on one vertex (" + ExactText(plus.x()) + ", " +
                                ExactText(plus.y()) + "), not on a base edge");
  }
  if (!(centroid.y() > y_min)) throw std::invalid_argument("vertices_m: centroid is not above the base");
  if (!(centroid.x() < plus.x()) || !(centroid.x() > minus.x())) {
    throw std::invalid_argument("vertices_m: centroid x " + ExactText(centroid.x()) +
                                " m is not between the pivots at x = " + ExactText(minus.x()) + " and " +
                                ExactText(plus.x()) + " m: the section does not stand on its base");
  }
  auto side = [&](const Eigen::Vector2d& pivot, int sign) {
    SideGeometry s;
    const Eigen::Vector2d r = centroid - pivot;
    s.pivot_m = pivot;
    s.R = r.norm();
    s.alpha = std::atan2(-sign * r.x(), r.y());
    s.i_o_per_area = i_g_per_area + r.squaredNorm();
    s.p = std::sqrt(g * s.R / s.i_o_per_area);
    return s;
  };
  BlockGeometry out;
  out.area = area;
  out.centroid_m = centroid;
  out.i_g_per_area = i_g_per_area;
  out.plus = side(plus, +1);
  out.minus = side(minus, -1);
  // Angular momentum about the new pivot (see the header).
  const double r_dot = (centroid - plus).dot(centroid - minus);
  out.plus.mu = (i_g_per_area + r_dot) / out.plus.i_o_per_area;
  out.minus.mu = (i_g_per_area + r_dot) / out.minus.i_o_per_area;
  out.R = out.plus.R;
  out.alpha = out.plus.alpha;
  out.p = out.plus.p;
  out.i_o_per_area = out.plus.i_o_per_area;
  out.mu_general = out.plus.mu;
  const double s = std::sin(out.alpha);
  out.mu_housner = 1.0 - 1.5 * s * s;
  auto same = [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)); };
  out.symmetric = same(out.plus.alpha, out.minus.alpha) && same(out.plus.p, out.minus.p) &&
                  same(out.plus.mu, out.minus.mu);
  return out;
}

namespace {

std::string TrimText(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

bool ParseNumber(const std::string& text, double& v) {
  const std::string t = TrimText(text);
  if (t.empty()) return false;
  char* end = nullptr;
  v = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size() && std::isfinite(v);
}

}  // namespace

PolygonFile ReadPolygonCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open the polygon file");
  PolygonFile out;
  out.path = path;
  std::string text;
  int line_no = 0;
  bool header = false;
  auto fail = [&](int line, const std::string& what) {
    throw std::invalid_argument(path + ":" + std::to_string(line) + ": " + what);
  };
  while (std::getline(in, text)) {
    common::PollThreadCancel();
    ++line_no;
    const std::string t = TrimText(text);
    if (t.empty() || t[0] == '#') continue;
    const auto comma = t.find(',');
    if (!header) {
      if (comma == std::string::npos || TrimText(t.substr(0, comma)) != "x" || TrimText(t.substr(comma + 1)) != "z") {
        fail(line_no, "the header must be x,z (m), got " + common::Quote(t));
      }
      header = true;
      continue;
    }
    double x = 0.0;
    double z = 0.0;
    if (comma == std::string::npos || t.find(',', comma + 1) != std::string::npos ||
        !ParseNumber(t.substr(0, comma), x) || !ParseNumber(t.substr(comma + 1), z)) {
      fail(line_no, "expected two finite numbers x,z (m), got " + common::Quote(t));
    }
    out.vertices_m.emplace_back(x, z);
    out.line.push_back(line_no);
  }
  if (!header) throw std::invalid_argument(path + ": empty file (no x,z header)");
  if (out.vertices_m.size() > 3 && out.vertices_m.front() == out.vertices_m.back()) {
    out.vertices_m.pop_back();  // a closed outline: the last vertex repeats the first
    out.line.pop_back();
  }
  const std::size_t n = out.vertices_m.size();
  if (n < 3) {
    throw std::invalid_argument(path + ": a polygon needs at least 3 vertices (got " + std::to_string(n) + ")");
  }
  const double tie = 1e-12 * std::max(Scale(out.vertices_m), 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    if ((out.vertices_m[i] - out.vertices_m[j]).cwiseAbs().maxCoeff() <= tie) {
      fail(out.line[j], "repeats the vertex of line " + std::to_string(out.line[i]));
    }
  }
  if (const auto crossing = FindCrossingEdges(out.vertices_m)) {
    const auto [i, j] = *crossing;
    fail(out.line[i], "the edge from line " + std::to_string(out.line[i]) + " to line " +
                          std::to_string(out.line[(i + 1) % n]) + " touches or crosses the edge from line " +
                          std::to_string(out.line[j]) + " to line " + std::to_string(out.line[(j + 1) % n]) +
                          ": not a simple polygon");
  }
  return out;
}

BlockGeometry PolygonBlock(const PolygonFile& polygon, double g) {
  try {
    return PolygonBlock(polygon.vertices_m, g);
  } catch (const std::invalid_argument& e) {
    std::string what = e.what();
    const std::string prefix = "vertices_m: ";
    if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
    throw std::invalid_argument(polygon.path + ": " + what);
  }
}

}  // namespace rocklab::model
