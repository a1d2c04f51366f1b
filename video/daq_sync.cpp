#include "video/daq_sync.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace rocklab::video {
namespace {

// A normalised level below this is off, above 1 - this on; between: the
// sample saw the switch.
constexpr double kSyncSettled = 0.03;

double SyncPercentile(std::vector<double> v, double q) {
  const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string SyncMs(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f ms", 1e3 * s);
  return b;
}

// The DAQ edge of `rising` nearest `t`, or NaN.
double NearestSyncEdge(const std::vector<double>& sorted, double t) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t);
  double best = std::numeric_limits<double>::quiet_NaN();
  if (it != sorted.end()) best = *it;
  if (it != sorted.begin() && (std::isnan(best) || t - *(it - 1) < best - t)) best = *(it - 1);
  return best;
}

struct SyncPairs {
  std::vector<double> x, y;  // video, DAQ times
};

struct LineFit {
  double a{}, b{1}, se_a{}, se_b{}, rms{}, max{};
};

LineFit FitSyncLine(const SyncPairs& p) {
  const double n = static_cast<double>(p.x.size());
  double xm = 0, ym = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i) xm += p.x[i] / n, ym += p.y[i] / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    sxx += (p.x[i] - xm) * (p.x[i] - xm);
    sxy += (p.x[i] - xm) * (p.y[i] - ym);
  }
  LineFit f;
  f.b = sxx > 0 ? sxy / sxx : 1.0;
  f.a = ym - f.b * xm;
  double rss = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    const double r = p.y[i] - f.a - f.b * p.x[i];
    rss += r * r;
    f.max = std::max(f.max, std::abs(r));
  }
  f.rms = std::sqrt(rss / n);
  const double s = n > 2 ? std::sqrt(rss / (n - 2)) : 0.0;
  f.se_b = sxx > 0 ? s / std::sqrt(sxx) : std::numeric_limits<double>::infinity();
  f.se_a = sxx > 0 ? s * std::sqrt(1 / n + xm * xm / sxx) : std::numeric_limits<double>::infinity();
  return f;
}

// The DAQ's columns on `grid` (ascending, at least 2 points) as the
// least-squares chord of the DAQ's own chord between its samples: the
// values c_k whose chord between the grid's points is nearest, in the
// integral of the squared difference, to the DAQ's chord (its L2
// projection on the hat functions of the grid), the interpolant the model
// and the fit draw between a record's samples. Point samples put the chord
// below a peak by a'' h^2 / 8 between them (docs/video.md, "In step with
// the DAQ"); the projection keeps each point's local mean. The normal
// equations are tridiagonal: sum_j M_kj c_j = b_k with M the hats' Gram
// matrix (h/6, 2h/3, h/6; h/3 at the ends) and b_k the integral of the
// DAQ's chord times hat k, exact by Simpson's rule on each piece between
// the DAQ's and the grid's points (both linear there). An interval of the
// grid the DAQ record does not cover, or with a non-finite sample, splits
// the chord into runs solved apart; a point in none is NaN. Per column.
std::vector<std::vector<double>> SyncChord(const Record& daq, const std::vector<double>& grid) {
  const std::size_t n = grid.size(), cols = daq.names.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::vector<double>> out(cols, std::vector<double>(n, nan));
  if (n < 2 || daq.t_s.size() < 2) return out;
  // Per column: b_k, and whether interval [k, k + 1] is covered and finite.
  std::vector<std::vector<double>> b(cols, std::vector<double>(n, 0.0));
  std::vector<std::vector<char>> ok(cols, std::vector<char>(n - 1, 0));
  const std::vector<double>& td = daq.t_s;
  // The DAQ's chord of column c at t inside [td[i], td[i + 1]].
  auto chord_at = [&daq, &td](std::size_t i, std::size_t c, double t) {
    const double w = (t - td[i]) / (td[i + 1] - td[i]);
    return daq.rows[i][c] + w * (daq.rows[i + 1][c] - daq.rows[i][c]);
  };
  std::size_t i = 0;  // DAQ interval [td[i], td[i + 1]] holding the piece's start
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double g0 = grid[k], g1 = grid[k + 1], h = g1 - g0;
    if (!(td.front() <= g0 && td.back() >= g1 && h > 0)) continue;
    while (i + 2 < td.size() && td[i + 1] <= g0) ++i;
    std::vector<double> lo(cols, 0.0), hi(cols, 0.0);
    std::vector<char> finite(cols, 1);
    double s0 = g0;
    for (std::size_t j = i; s0 < g1; ++j) {
      const double s1 = std::min(g1, td[j + 1]);
      if (s1 > s0) {
        const double sm = 0.5 * (s0 + s1), len = s1 - s0;
        for (std::size_t c = 0; c < cols; ++c) {
          const double x0 = chord_at(j, c, s0), xm = chord_at(j, c, sm), x1 = chord_at(j, c, s1);
          finite[c] = finite[c] && std::isfinite(x0) && std::isfinite(x1);
          // Hats: (g1 - t) / h for point k, (t - g0) / h for point k + 1.
          lo[c] += len / 6 * (x0 * (g1 - s0) + 4 * xm * (g1 - sm) + x1 * (g1 - s1)) / h;
          hi[c] += len / 6 * (x0 * (s0 - g0) + 4 * xm * (sm - g0) + x1 * (s1 - g0)) / h;
        }
      }
      s0 = s1;
    }
    for (std::size_t c = 0; c < cols; ++c) {
      if (!finite[c]) continue;
      ok[c][k] = 1;
      b[c][k] += lo[c];
      b[c][k + 1] += hi[c];
    }
  }
  std::vector<double> diag, sup, rhs;
  for (std::size_t c = 0; c < cols; ++c) {
    for (std::size_t k0 = 0; k0 + 1 < n;) {
      if (!ok[c][k0]) {
        ++k0;
        continue;
      }
      std::size_t k1 = k0;  // the run's intervals: k0 .. k1 - 1, points k0 .. k1
      while (k1 + 1 < n && ok[c][k1]) ++k1;
      const std::size_t m = k1 - k0 + 1;
      diag.assign(m, 0.0);
      sup.assign(m, 0.0);
      rhs.assign(m, 0.0);
      for (std::size_t k = k0; k < k1; ++k) {
        const double h = grid[k + 1] - grid[k];
        diag[k - k0] += h / 3;
        diag[k - k0 + 1] += h / 3;
        sup[k - k0] = h / 6;
      }
      // b at the run's ends holds only the run's side (runs are maximal).
      for (std::size_t k = k0; k <= k1; ++k) rhs[k - k0] = b[c][k];
      // Thomas's algorithm (the Gram matrix is diagonally dominant).
      for (std::size_t r = 1; r < m; ++r) {
        const double f = sup[r - 1] / diag[r - 1];
        diag[r] -= f * sup[r - 1];
        rhs[r] -= f * rhs[r - 1];
      }
      out[c][k1] = rhs[m - 1] / diag[m - 1];
      for (std::size_t r = m - 1; r-- > 0;) out[c][k0 + r] = (rhs[r] - sup[r] * out[c][k0 + r + 1]) / diag[r];
      k0 = k1;
    }
  }
  return out;
}

}  // namespace

std::vector<SyncEdge> FindSyncEdges(const std::vector<double>& t_s, const std::vector<double>& level,
                                    double exposure_s, double max_gap_s, double* contrast) {
  std::vector<double> finite;
  for (double v : level) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  *contrast = 0;
  std::vector<SyncEdge> edges;
  if (finite.size() < 2) return edges;
  const double lo = SyncPercentile(finite, 0.1), hi = SyncPercentile(finite, 0.9);
  *contrast = hi - lo;
  if (!(hi > lo)) return edges;
  int state = -1;        // last settled state: 0 off, 1 on, -1 not known
  std::size_t last = 0;  // its sample
  for (std::size_t i = 0; i < level.size(); ++i) {
    if (!std::isfinite(level[i]) || (i > 0 && t_s[i] - t_s[i - 1] > max_gap_s)) {
      state = -1;  // no edge across a missing sample or a drop
      if (!std::isfinite(level[i])) continue;
    }
    const double f = (level[i] - lo) / (hi - lo);
    const int now = f < kSyncSettled ? 0 : f > 1 - kSyncSettled ? 1 : -1;
    if (now < 0) continue;
    if (state >= 0 && now != state) {
      const bool rising = now == 1;
      double t = 0;
      if (exposure_s > 0 && i > last + 1) {
        // A sample that saw the switch: the one nearest half-way.
        std::size_t k = last + 1;
        for (std::size_t j = last + 1; j < i; ++j) {
          const double fj = (level[j] - lo) / (hi - lo), fk = (level[k] - lo) / (hi - lo);
          if (std::abs(fj - 0.5) < std::abs(fk - 0.5)) k = j;
        }
        const double fk = std::clamp((level[k] - lo) / (hi - lo), 0.0, 1.0);
        const double start = t_s[k] - 0.5 * exposure_s;
        t = start + exposure_s * (rising ? 1 - fk : fk);
      } else if (i > last + 1) {
        // Instantaneous samples: the half-way crossing, linear between the
        // two samples around it.
        std::size_t k = last;
        while (k + 1 < i && ((level[k + 1] - lo) / (hi - lo) < 0.5) == !rising) ++k;
        const double f0 = (level[k] - lo) / (hi - lo), f1 = (level[k + 1] - lo) / (hi - lo);
        const double w = f1 != f0 ? std::clamp((0.5 - f0) / (f1 - f0), 0.0, 1.0) : 0.5;
        t = t_s[k] + w * (t_s[k + 1] - t_s[k]);
      } else {
        // Between two exposures: the middle of the dark time between them.
        t = 0.5 * ((t_s[last] + 0.5 * exposure_s) + (t_s[i] - 0.5 * exposure_s));
      }
      edges.push_back({t, rising});
    }
    state = now;
    last = i;
  }
  return edges;
}

ClockFit FitClock(const std::vector<SyncEdge>& video, const std::vector<SyncEdge>& daq, double frame_period_s,
                  double exposure_s, double daq_period_s, const std::string& what) {
  ClockFit fit;
  fit.video_edges = static_cast<int>(video.size());
  fit.daq_edges = static_cast<int>(daq.size());
  // Uniform errors: the dark time between exposures, a DAQ period, and the
  // settled bands at both ends of an exposure (an edge seen there is put at
  // the exposure's end).
  fit.expected_rms_s = std::sqrt((std::pow(std::max(0.0, frame_period_s - exposure_s), 2) +
                                  daq_period_s * daq_period_s + std::pow(2 * kSyncSettled * exposure_s, 2)) /
                                 12);
  if (video.size() < 4 || daq.size() < 4) {
    throw std::runtime_error(what + ": the sync LED switched " + std::to_string(video.size()) +
                             " times in the video and its channel " + std::to_string(daq.size()) +
                             " times in the DAQ record: at least 4 edges are needed in each");
  }
  std::vector<double> sense[2];
  for (const SyncEdge& e : daq) sense[e.rising ? 1 : 0].push_back(e.t_s);
  for (auto& s : sense) std::sort(s.begin(), s.end());
  // The coarse offset: each DAQ edge against 8 anchor edges spread over
  // the video (a video that starts before the DAQ record still has some
  // inside it), scored by how many of the 64 video edges nearest the anchor
  // have a DAQ edge of the same sense within a frame and a DAQ period
  // (twice what the two edges' errors can add up to), the tolerance growing
  // by kMaxSyncDriftPpm with the distance from the anchor.
  const double tol0 = frame_period_s + daq_period_s;
  const double slack = 1e-6 * kMaxSyncDriftPpm;
  auto window = [&video](std::size_t anchor) {
    const std::size_t lo = anchor > 32 ? anchor - 32 : 0;
    return std::make_pair(lo, std::min(video.size(), lo + 64));
  };
  auto score = [&](std::size_t anchor, double c) {
    int n = 0;
    const auto [lo, hi] = window(anchor);
    for (std::size_t i = lo; i < hi; ++i) {
      const double want = video[i].t_s + c;
      const double d = NearestSyncEdge(sense[video[i].rising ? 1 : 0], want);
      n += std::abs(d - want) <= tol0 + slack * std::abs(video[i].t_s - video[anchor].t_s) ? 1 : 0;
    }
    return n;
  };
  struct Candidate {
    int score;
    double offset;
    std::size_t anchor;
  };
  std::vector<Candidate> candidates;
  const std::size_t anchors = std::min<std::size_t>(video.size(), 8);
  for (std::size_t k = 0; k < anchors; ++k) {
    const std::size_t i = k * video.size() / anchors;
    for (double d : sense[video[i].rising ? 1 : 0]) candidates.push_back({score(i, d - video[i].t_s), d - video[i].t_s, i});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.score > y.score; });
  const Candidate best = candidates.front();
  int second = 0;
  for (const Candidate& c : candidates) {
    // Another alignment of the same anchor's neighbourhood.
    if (c.anchor == best.anchor && std::abs(c.offset - best.offset) > 2 * tol0) {
      second = c.score;
      break;
    }
  }
  if (best.score < 4) {
    throw std::runtime_error(what + ": no offset pairs 4 of the sync LED's edges in the video with its channel's "
                             "(is sync_channel the column that drives the LED, and did both record the same time?)");
  }
  if (second >= 0.6 * best.score) {
    throw std::runtime_error(what + ": the sync LED's edges pair at two offsets (" + std::to_string(best.offset) +
                             " s with " + std::to_string(best.score) + " edges, another with " +
                             std::to_string(second) + "): drive the LED at irregular intervals");
  }
  // Pairs: each video edge with the nearest DAQ edge of its sense where the
  // clock (a, b) puts it, within tol (+ slack x its distance outside [lo, hi]).
  auto pair = [&](double a, double b, double tol, double lo, double hi) {
    SyncPairs p;
    for (const SyncEdge& e : video) {
      const double out = std::max({0.0, lo - e.t_s, e.t_s - hi});
      if (out > std::max(hi - lo, 10.0)) continue;  // not yet: the range grows at most twice a round
      const double want = a + b * e.t_s;
      const double d = NearestSyncEdge(sense[e.rising ? 1 : 0], want);
      if (std::abs(d - want) <= tol + slack * out) p.x.push_back(e.t_s), p.y.push_back(d);
    }
    return p;
  };
  // Grown from the anchor: fit, pair further out with the fitted clock, again.
  LineFit line;
  line.a = best.offset;
  double lo = video[best.anchor].t_s, hi = lo;
  SyncPairs p;
  for (std::size_t before = 0;;) {
    p = pair(line.a, line.b, tol0, lo, hi);
    if (p.x.size() >= 4) {
      line = FitSyncLine(p);
    } else if (!p.x.empty()) {
      line.a = 0;  // too few for a slope: the offset alone
      for (std::size_t i = 0; i < p.x.size(); ++i) line.a += (p.y[i] - line.b * p.x[i]) / p.x.size();
    }
    if (!p.x.empty()) {
      lo = *std::min_element(p.x.begin(), p.x.end());
      hi = *std::max_element(p.x.begin(), p.x.end());
    }
    if (p.x.size() <= before) break;  // nothing new within reach
    before = p.x.size();
  }
  // Once more over the whole video with the fitted clock.
  const double tol1 = tol0;
  p = pair(line.a, line.b, tol1, video.front().t_s, video.back().t_s);
  if (p.x.size() < 4) {
    throw std::runtime_error(what + ": only " + std::to_string(p.x.size()) +
                             " of the sync LED's edges pair within a frame and a DAQ period of the fitted clock");
  }
  line = FitSyncLine(p);
  fit.offset_s = line.a;
  fit.drift_ppm = 1e6 * (line.b - 1);
  fit.offset_se_s = line.se_a;
  fit.drift_se_ppm = 1e6 * line.se_b;
  fit.residual_rms_s = line.rms;
  fit.residual_max_s = line.max;
  fit.matched = static_cast<int>(p.x.size());
  // Video edges the DAQ record spans: each should have paired.
  const double d0 = daq.front().t_s, d1 = daq.back().t_s;
  int inside = 0;
  for (const SyncEdge& e : video) {
    const double t = fit.DaqTime(e.t_s);
    inside += t >= d0 - tol1 && t <= d1 + tol1 ? 1 : 0;
  }
  if (fit.matched < 0.8 * inside) {
    throw std::runtime_error(what + ": only " + std::to_string(fit.matched) + " of the " + std::to_string(inside) +
                             " sync LED edges in the DAQ record's time pair with its channel's (fewer than 80 %)");
  }
  if (std::abs(fit.drift_ppm) > kMaxSyncDriftPpm) {
    throw std::runtime_error(what + ": the clocks drift by " + std::to_string(fit.drift_ppm) +
                             " ppm, more than a camera's or a DAQ's clock can (1000 ppm): the edges are paired wrongly");
  }
  const double plausible = std::max(3 * fit.expected_rms_s, 0.02 * frame_period_s);
  if (fit.residual_rms_s > plausible) {
    throw std::runtime_error(what + ": the sync edges scatter by " + SyncMs(fit.residual_rms_s) +
                             " RMS about the fitted clock, more than 3x the " + SyncMs(fit.expected_rms_s) +
                             " the frame and DAQ periods allow (a clipped sync LED, whose light is not linear in "
                             "its on time, or a clock that jumps)");
  }
  return fit;
}

namespace {

// The DAQ's chord of x at t (t inside the record).
double MotionChordAt(const std::vector<double>& t, const std::vector<double>& x, double at) {
  const auto it = std::upper_bound(t.begin(), t.end(), at);
  const std::size_t j = std::clamp<std::size_t>(static_cast<std::size_t>(it - t.begin()), 1, t.size() - 1);
  const double w = (at - t[j - 1]) / (t[j] - t[j - 1]);
  return x[j - 1] + w * (x[j] - x[j - 1]);
}

// Pearson's correlation of xv with the DAQ's chord at tv + c.
double MotionCorrelation(const std::vector<double>& tv, const std::vector<double>& xv, const std::vector<double>& td,
                         const std::vector<double>& xd, double c) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  const double n = static_cast<double>(tv.size());
  for (std::size_t k = 0; k < tv.size(); ++k) {
    const double a = xv[k], b = MotionChordAt(td, xd, tv[k] + c);
    sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
  }
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  return va > 0 && vb > 0 ? (sab - sa * sb / n) / std::sqrt(va * vb) : 0.0;
}

// Solves the 4 x 4 system m y = r in place (Gauss-Jordan, partial pivots);
// false when singular. `inv` receives m's inverse.
bool MotionSolve4(double m[4][4], double r[4], double inv[4][4]) {
  double a[4][8];
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) a[i][j] = m[i][j], a[i][j + 4] = i == j ? 1.0 : 0.0;
  }
  for (int c = 0; c < 4; ++c) {
    int p = c;
    for (int i = c + 1; i < 4; ++i) p = std::abs(a[i][c]) > std::abs(a[p][c]) ? i : p;
    if (!(std::abs(a[p][c]) > 0)) return false;
    for (int j = 0; j < 8; ++j) std::swap(a[c][j], a[p][j]);
    const double d = a[c][c];
    for (int j = 0; j < 8; ++j) a[c][j] /= d;
    for (int i = 0; i < 4; ++i) {
      if (i == c) continue;
      const double f = a[i][c];
      for (int j = 0; j < 8; ++j) a[i][j] -= f * a[c][j];
    }
  }
  double y[4] = {};
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) inv[i][j] = a[i][j + 4], y[i] += inv[i][j] * r[j];
  }
  for (int i = 0; i < 4; ++i) r[i] = y[i];
  return true;
}

}  // namespace

MotionFit FitClockByMotion(const std::vector<double>& t_video, const std::vector<double>& x_video,
                           const std::vector<double>& t_daq, const std::vector<double>& x_daq,
                           double daq_period_s, const std::string& what) {
  std::vector<double> tv, xv;
  for (std::size_t k = 0; k < t_video.size(); ++k) {
    if (std::isfinite(x_video[k])) tv.push_back(t_video[k]), xv.push_back(x_video[k]);
  }
  std::vector<double> td, xd;
  for (std::size_t i = 0; i < t_daq.size(); ++i) {
    if (std::isfinite(x_daq[i])) td.push_back(t_daq[i]), xd.push_back(x_daq[i]);
  }
  if (tv.size() < 20 || td.size() < 2) {
    throw std::runtime_error(what + ": " + std::to_string(tv.size()) +
                             " frames show the table's motion (at least 20 are needed)");
  }
  const double lo = td.front() - tv.front(), hi = td.back() - tv.back();
  if (hi < lo) {
    throw std::runtime_error(what + ": the DAQ record (" + std::to_string(td.back() - td.front()) +
                             " s) is shorter than the video (" + std::to_string(tv.back() - tv.front()) +
                             " s): the table's motion cannot be found in it");
  }
  // Every offset a DAQ period apart (at most 20000 of them), the best
  // refined on the DAQ's periods around it.
  const double step = std::max(daq_period_s, (hi - lo) / 20000);
  std::vector<double> offsets, corr;
  for (double c = lo; c <= hi + 1e-12; c += step) offsets.push_back(c), corr.push_back(MotionCorrelation(tv, xv, td, xd, c));
  std::size_t best = 0;
  for (std::size_t i = 1; i < corr.size(); ++i) best = std::abs(corr[i]) > std::abs(corr[best]) ? i : best;
  double second = 0;
  for (std::size_t i = 1; i + 1 < corr.size(); ++i) {
    const bool peak = std::abs(corr[i]) >= std::abs(corr[i - 1]) && std::abs(corr[i]) >= std::abs(corr[i + 1]);
    if (peak && std::abs(offsets[i] - offsets[best]) > 4 * std::max(step, daq_period_s)) {
      second = std::max(second, std::abs(corr[i]));
    }
  }
  double c0 = offsets[best];
  if (step > daq_period_s) {
    double bc = std::abs(corr[best]);
    for (double c = offsets[best] - step; c <= offsets[best] + step; c += daq_period_s) {
      const double r = std::abs(MotionCorrelation(tv, xv, td, xd, c));
      if (r > bc && c >= lo && c <= hi) bc = r, c0 = c;
    }
  }
  MotionFit out;
  out.correlation = MotionCorrelation(tv, xv, td, xd, c0);
  if (std::abs(out.correlation) < 0.9) {
    throw std::runtime_error(what + ": the table's motion in the video correlates " +
                             std::to_string(out.correlation) +
                             " at best with the DAQ's sync_channel (below 0.9: is it the table's displacement, "
                             "and did the table move while filmed?)");
  }
  if (second >= 0.99 * std::abs(out.correlation)) {
    throw std::runtime_error(what + ": the table's motion matches at two offsets (correlation " +
                             std::to_string(std::abs(out.correlation)) + " and " + std::to_string(second) +
                             "): a periodic motion cannot set the clocks; record its start and end");
  }
  // Gauss-Newton on (offset, drift, scale, level).
  double p[4] = {c0, 0.0, 0.0, 0.0};
  {
    // Scale and level by least squares at the offset found.
    double sa = 0, sb = 0, sbb = 0, sab = 0;
    const double n = static_cast<double>(tv.size());
    for (std::size_t k = 0; k < tv.size(); ++k) {
      const double b = MotionChordAt(td, xd, tv[k] + c0);
      sa += xv[k], sb += b, sbb += b * b, sab += xv[k] * b;
    }
    p[2] = (sab - sa * sb / n) / (sbb - sb * sb / n);
    p[3] = (sa - p[2] * sb) / n;
  }
  const double h = std::max(daq_period_s, 1e-6);
  double cov[4][4] = {};
  double rss = 0;
  for (int iter = 0; iter < 20; ++iter) {
    double m[4][4] = {}, r[4] = {};
    rss = 0;
    for (std::size_t k = 0; k < tv.size(); ++k) {
      const double tau = std::clamp(p[0] + (1 + p[1]) * tv[k], td.front() + h, td.back() - h);
      const double d = MotionChordAt(td, xd, tau);
      const double slope = (MotionChordAt(td, xd, tau + h) - MotionChordAt(td, xd, tau - h)) / (2 * h);
      const double j[4] = {p[2] * slope, p[2] * slope * tv[k], d, 1.0};
      const double e = xv[k] - (p[2] * d + p[3]);
      rss += e * e;
      for (int a = 0; a < 4; ++a) {
        r[a] += j[a] * e;
        for (int b = 0; b < 4; ++b) m[a][b] += j[a] * j[b];
      }
    }
    if (!MotionSolve4(m, r, cov)) throw std::runtime_error(what + ": the table's motion does not fix the clocks");
    for (int a = 0; a < 4; ++a) p[a] += r[a];
    if (std::abs(r[0]) < 1e-9 && std::abs(r[1]) < 1e-12) break;
  }
  const double n = static_cast<double>(tv.size());
  const double s2 = rss / (n - 4);
  out.clock.offset_s = p[0];
  out.clock.drift_ppm = 1e6 * p[1];
  out.clock.offset_se_s = std::sqrt(s2 * cov[0][0]);
  out.clock.drift_se_ppm = 1e6 * std::sqrt(s2 * cov[1][1]);
  out.scale = p[2];
  out.residual_rms = std::sqrt(rss / n);
  out.samples = static_cast<int>(tv.size());
  if (std::abs(out.clock.drift_ppm) > kMaxSyncDriftPpm) {
    throw std::runtime_error(what + ": the clocks drift by " + std::to_string(out.clock.drift_ppm) +
                             " ppm by the table's motion, more than a camera's or a DAQ's clock can (1000 ppm)");
  }
  return out;
}

Record MergeOnDaqClock(const Record& daq, const Record& video, const std::vector<Resample>& kinds,
                       const ClockFit& fit, double frame_period_s, double grid_rate_hz, MergeCounts* counts) {
  Record out;
  out.names = daq.names;
  for (const std::string& n : video.names) {
    if (std::find(daq.names.begin(), daq.names.end(), n) != daq.names.end()) {
      throw std::runtime_error("the video's channel '" + n + "' is also a column of the DAQ record");
    }
    out.names.push_back(n);
  }
  *counts = MergeCounts{};
  if (video.t_s.empty() || daq.t_s.empty()) return out;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double first = fit.DaqTime(video.t_s.front()), last = fit.DaqTime(video.t_s.back());
  // The video's channels at DAQ time t appended to `row`.
  auto add_video = [&](double t, std::vector<double>& row) {
    const double tv = fit.VideoTime(t);
    std::size_t i = static_cast<std::size_t>(std::upper_bound(video.t_s.begin(), video.t_s.end(), tv) -
                                             video.t_s.begin());
    i = i == 0 ? 0 : i - 1;
    const std::size_t j = std::min(i + 1, video.t_s.size() - 1);
    const double dt = video.t_s[j] - video.t_s[i];
    const double w = dt > 0 ? std::clamp((tv - video.t_s[i]) / dt, 0.0, 1.0) : 0.0;
    const bool gap = dt > 1.5 * frame_period_s;
    counts->in_gaps += gap ? 1 : 0;
    const std::vector<double>& a = video.rows[i];
    const std::vector<double>& b = video.rows[j];
    for (std::size_t c = 0; c < video.names.size(); ++c) {
      const double nearest = w < 0.5 ? a[c] : b[c];
      switch (kinds[c]) {
        case Resample::kLinear: row.push_back(gap ? nan : a[c] + w * (b[c] - a[c])); break;
        case Resample::kNearest: row.push_back(nearest); break;
        case Resample::kFlags: row.push_back(gap ? 2.0 : nearest); break;
      }
    }
  };
  for (double t : daq.t_s) {
    counts->before += t < first ? 1 : 0;
    counts->after += t > last ? 1 : 0;
  }
  if (grid_rate_hz <= 0) {
    for (std::size_t r = 0; r < daq.t_s.size(); ++r) {
      if (daq.t_s[r] < first || daq.t_s[r] > last) continue;
      std::vector<double> row = daq.rows[r];
      add_video(daq.t_s[r], row);
      out.t_s.push_back(daq.t_s[r]);
      out.rows.push_back(std::move(row));
    }
  } else {
    // The camera's rate on the DAQ's clock: the video's channels at each
    // point, the DAQ's as the least-squares chord of their own (SyncChord).
    const double step = 1 / grid_rate_hz;
    for (int64_t k = 0;; ++k) {
      const double t = first + static_cast<double>(k) * step;
      if (t > last) break;
      out.t_s.push_back(t);
    }
    const std::vector<std::vector<double>> chord = SyncChord(daq, out.t_s);
    for (std::size_t k = 0; k < out.t_s.size(); ++k) {
      std::vector<double> row(daq.names.size());
      for (std::size_t c = 0; c < row.size(); ++c) row[c] = chord[c][k];
      add_video(out.t_s[k], row);
      out.rows.push_back(std::move(row));
    }
  }
  counts->rows = static_cast<int64_t>(out.t_s.size());
  return out;
}

}  // namespace rocklab::video
