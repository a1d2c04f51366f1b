#include "report/report_figure.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <thread>

#include "common/atomic_file.h"
#include "common/provenance.h"

extern char** environ;

namespace rocklab::report {

// Text inside a gnuplot single-quoted string: '' is a quote, nothing else is
// special (no backslash escapes); control characters become spaces.
std::string GnuplotQuoted(const std::string& text) {
  std::string out = "'";
  for (char c : text) {
    if (c == '\'') {
      out += "''";
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out + "'";
}

namespace {

std::string Quoted(const std::string& text) { return GnuplotQuoted(text); }

void AppendNumber(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "NaN";
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);  // 9 digits: below any visible resolution
  out += buf;
}

// One line from gnuplot's stderr for an error message: its own complaints
// without the echoed command and the caret under it.
std::string Complaint(const std::string& err) {
  std::istringstream in(err);
  std::string line, out;
  while (std::getline(in, line)) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos) continue;
    line = line.substr(first);
    if (line.rfind("gnuplot>", 0) == 0 || line.find_first_not_of("^ \t") == std::string::npos) {
      continue;
    }
    out += (out.empty() ? "" : "; ") + line;
  }
  return out.empty() ? "no message" : out;
}

std::string Warnings(const std::string& err) {
  std::istringstream in(err);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.find("warning") == std::string::npos) continue;
    const auto first = line.find_first_not_of(" \t");
    out += (out.empty() ? "" : "\n") + line.substr(first);
  }
  return out;
}

// Closes a descriptor once.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() { Close(); }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_;
};

// Writes all of `text` to a pipe with SIGPIPE blocked in this thread, so a
// gnuplot that died early gives EPIPE here instead of killing the process.
// Returns false when the reader went away.
bool WriteAll(int fd, const std::string& text) {
  sigset_t pipe_set, old_set;
  sigemptyset(&pipe_set);
  sigaddset(&pipe_set, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_set, &old_set);
  bool ok = true;
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ok = false;
      break;
    }
    done += static_cast<std::size_t>(n);
  }
  if (!ok && errno == EPIPE) {
    const timespec zero{};
    sigtimedwait(&pipe_set, nullptr, &zero);  // consume the pending SIGPIPE
  }
  pthread_sigmask(SIG_SETMASK, &old_set, nullptr);
  return ok;
}

// Layout in pixels: the caption sits under the x label, one line per entry;
// the plot takes the rest. Sizes follow the font size, whichever face renders it.
struct Layout {
  Layout(FigureFormat format, std::size_t caption_lines, bool table_panel, std::size_t body_panels = 0)
      : font_pt(format == FigureFormat::kSvg ? 11.0 : 10.0),
        line_px(1.6 * font_pt),
        caption_px(line_px * (static_cast<double>(caption_lines) + 0.5)),
        bottom_px(caption_px + 3.2 * line_px),  // tick labels and the x label above
        plot_min_px((table_panel ? 180 : 100) + 100 * static_cast<double>(body_panels)) {}
  /// Height the figure needs: the bottom, the plots, the title above.
  int min_height_px() const {
    return static_cast<int>(std::ceil(bottom_px + plot_min_px + 3 * line_px));
  }
  double font_pt, line_px, caption_px, bottom_px, plot_min_px;
};

// The [min, max] of the finite values of some vectors; false when none.
bool Span(const std::vector<const std::vector<double>*>& all, double& lo, double& hi) {
  lo = std::numeric_limits<double>::infinity();
  hi = -lo;
  for (const auto* v : all) {
    for (double x : *v) {
      if (!std::isfinite(x)) continue;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  }
  return lo < hi;
}

}  // namespace

void ThetaFigure::AddCurve(ThetaCurve curve) {
  if (curve.time_s.size() != curve.theta_deg.size()) {
    throw std::invalid_argument("curve '" + curve.title + "': " +
                                std::to_string(curve.time_s.size()) + " times but " +
                                std::to_string(curve.theta_deg.size()) + " angles");
  }
  curves_.push_back(std::move(curve));
}

void ThetaFigure::AddBand(ThetaBand band) {
  const std::size_t n = band.time_s.size();
  for (const auto* q : {&band.lo95_deg, &band.lo68_deg, &band.median_deg, &band.hi68_deg, &band.hi95_deg}) {
    if (q->size() != n) {
      throw std::invalid_argument("band '" + band.title + "': " + std::to_string(n) + " times but " +
                                  std::to_string(q->size()) + " values of a quantile");
    }
  }
  bands_.push_back(std::move(band));
}

void ThetaFigure::AddBodyPanel(std::string label, std::vector<ThetaCurve> curves) {
  for (const ThetaCurve& c : curves) {
    if (c.time_s.size() != c.theta_deg.size()) {
      throw std::invalid_argument("curve '" + c.title + "': " + std::to_string(c.time_s.size()) +
                                  " times but " + std::to_string(c.theta_deg.size()) + " angles");
    }
  }
  body_panels_.push_back({std::move(label), std::move(curves)});
}

void ThetaFigure::SetTableAcceleration(std::vector<double> time_s, std::vector<double> accel_mps2) {
  if (time_s.size() != accel_mps2.size()) {
    throw std::invalid_argument("table acceleration: " + std::to_string(time_s.size()) +
                                " times but " + std::to_string(accel_mps2.size()) + " values");
  }
  table_time_s_ = std::move(time_s);
  table_accel_mps2_ = std::move(accel_mps2);
}

std::string ThetaFigure::Script(const std::string& out_path, FigureFormat format, int width_px,
                                int height_px) const {
  const bool panel = has_table_panel();
  // Several panels on one time axis (multiplot): the table's, an assembly's
  // upper bodies'. Without them the script is the single panel's.
  const bool multi = panel || !body_panels_.empty();
  const Layout layout(format, caption_.size(), panel, body_panels_.size());
  const double font_pt = layout.font_pt, line_px = layout.line_px;
  const double caption_px = layout.caption_px, bottom_px = layout.bottom_px;
  const double h = static_cast<double>(height_px);

  std::string s;
  s.reserve(4096);
  char buf[256];
  if (format == FigureFormat::kSvg) {
    std::snprintf(buf, sizeof buf,
                  "set terminal svg size %d,%d font 'sans-serif,%g' background '#ffffff'\n",
                  width_px, height_px, font_pt);
  } else {
    std::snprintf(buf, sizeof buf,
                  "set terminal pngcairo size %d,%d font 'sans,%g' background '#ffffff'\n",
                  width_px, height_px, font_pt);
  }
  s += buf;
  s += "set encoding utf8\n";
  s += "set output " + Quoted(out_path) + "\n";
  // Every text is plain (noenhanced): names and captions may hold _ ^ { } @ &.
  if (!title_.empty()) s += "set title " + Quoted(title_) + " noenhanced\n";
  // With the table panel: two plots on one time axis (multiplot), theta in
  // the top 62 % of the plotting height, the acceleration below it; fixed
  // left and right margins so the axes line up.
  double panel_top = 0, panel_split = 0;
  // An assembly: each theta panel one share of the plotting height, the
  // table's 0.38 / 0.62 of one (its share beside a single theta panel).
  double share = 0;
  if (multi) {
    std::vector<const std::vector<double>*> times{&table_time_s_};
    for (const ThetaCurve& c : curves_) times.push_back(&c.time_s);
    for (const BodyPanel& b : body_panels_) {
      for (const ThetaCurve& c : b.curves) times.push_back(&c.time_s);
    }
    double t_lo = 0, t_hi = 0;
    s += "set multiplot\nset lmargin 10\nset rmargin 3\n";
    if (Span(times, t_lo, t_hi)) {
      std::snprintf(buf, sizeof buf, "set xrange [%.9g:%.9g]\n", t_lo, t_hi);
      s += buf;
    }
    panel_top = 1.0 - 3 * line_px / h;  // the title above
    panel_split = bottom_px / h + 0.38 * (panel_top - bottom_px / h);
    if (!body_panels_.empty()) {
      const double table_share = panel ? 0.38 / 0.62 : 0.0;
      share = (panel_top - bottom_px / h) / (static_cast<double>(1 + body_panels_.size()) + table_share);
      panel_split = panel_top - share;  // under the bottom body's panel
    }
    s += "set xlabel ''\nset format x ''\nset ylabel 'theta (degrees)'\n";
  } else {
    s += "set xlabel 'time (s)'\nset ylabel 'theta (degrees)'\n";
  }
  // The key sits inside the top of the plot, over a band the y range keeps
  // free for it: 3 entries a row.
  const std::size_t key_rows = (curves_.size() + 3 * bands_.size() + 2) / 3;
  std::snprintf(buf, sizeof buf,
                "set grid\nset autoscale xfix\n"
                "set key inside top center horizontal maxcols 3\n"
                "set offsets 0, 0, graph %.2f, graph 0.02\n",
                0.06 + 0.07 * static_cast<double>(key_rows));
  s += buf;
  if (multi) {
    std::snprintf(buf, sizeof buf, "set tmargin at screen %.4f\nset bmargin at screen %.4f\n",
                  panel_top, panel_split + 0.01);
  } else {
    std::snprintf(buf, sizeof buf, "set bmargin at screen %.4f\n", bottom_px / h);
  }
  s += buf;
  for (std::size_t i = 0; i < caption_.size(); ++i) {
    const double y_px = caption_px - line_px * (static_cast<double>(i) + 1.0);
    std::snprintf(buf, sizeof buf, "set label %zu at screen 0.015, screen %.4f left ", i + 1,
                  (y_px + 0.3 * line_px) / h);
    s += buf + Quoted(caption_[i]) + " noenhanced\n";
  }

  // Model variants get distinct colours and dashes, the experiment solid black.
  static const char* const kColours[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e",
                                         "#9467bd", "#8c564b", "#e377c2", "#17becf"};
  std::string plot = "plot ";
  // The bands first, so that every curve is drawn over them.
  static const char* const kBandColours[] = {"#5a5ac8", "#c86e28", "#289678", "#a03ca0"};
  for (std::size_t i = 0; i < bands_.size(); ++i) {
    const ThetaBand& b = bands_[i];
    const std::string block = "$b" + std::to_string(i);
    s += block + " << EOD\n";
    for (std::size_t k = 0; k < b.time_s.size(); ++k) {
      for (double v : {b.time_s[k], b.lo95_deg[k], b.lo68_deg[k], b.median_deg[k], b.hi68_deg[k], b.hi95_deg[k]}) {
        AppendNumber(s, v);
        s += ' ';
      }
      s += '\n';
    }
    if (b.time_s.empty()) s += "NaN NaN NaN NaN NaN NaN\n";
    s += "EOD\n";
    const char* colour = kBandColours[i % 4];
    std::snprintf(buf, sizeof buf,
                  "%s using 1:2:6 with filledcurves fc rgb '%s' fs transparent solid 0.18 noborder title ",
                  block.c_str(), colour);
    plot += buf + Quoted(b.title + " 95 %") + " noenhanced, ";
    std::snprintf(buf, sizeof buf,
                  "%s using 1:3:5 with filledcurves fc rgb '%s' fs transparent solid 0.32 noborder title ",
                  block.c_str(), colour);
    plot += buf + Quoted(b.title + " 68 %") + " noenhanced, ";
    std::snprintf(buf, sizeof buf, "%s using 1:4 with lines lw 1.2 lc rgb '%s' dt 2 title ", block.c_str(), colour);
    plot += buf + Quoted(b.title + " median") + " noenhanced, ";
  }
  // A curve's data block into the script, its entry into `to_plot`: the
  // experiment solid black, the models each a colour and dash of their own.
  auto add_curve = [&](const ThetaCurve& c, const std::string& block, bool first, std::size_t& index,
                       std::string& to_plot) {
    s += block + " << EOD\n";
    for (std::size_t k = 0; k < c.time_s.size(); ++k) {
      AppendNumber(s, c.time_s[k]);
      s += ' ';
      AppendNumber(s, c.theta_deg[k]);
      s += '\n';
    }
    if (c.time_s.empty()) s += "NaN NaN\n";
    s += "EOD\n";
    to_plot += first ? "" : ", ";
    if (c.reference) {
      to_plot += block + " using 1:2 with lines lw 1.6 lc rgb '#000000' dt 1";
    } else {
      std::snprintf(buf, sizeof buf, " using 1:2 with lines lw 1.3 lc rgb '%s' dt %zu",
                    kColours[index % 8], 2 + index % 4);
      to_plot += block + buf;
      ++index;
    }
    to_plot += " title " + Quoted(c.title) + " noenhanced";
  };
  std::size_t model_index = 0;
  for (std::size_t i = 0; i < curves_.size(); ++i) {
    add_curve(curves_[i], "$c" + std::to_string(i), i == 0, model_index, plot);
  }
  s += plot + "\n";
  // An assembly's upper bodies, a panel each, the curves in the same order
  // and styles as above.
  for (std::size_t j = 0; j < body_panels_.size(); ++j) {
    const BodyPanel& b = body_panels_[j];
    const bool lowest = j + 1 == body_panels_.size() && !panel;
    s += "unset title\nunset label\n";
    s += lowest ? "set format x '% h'\nset xlabel 'time (s)'\n" : "set xlabel ''\nset format x ''\n";
    s += "set ylabel " + Quoted(b.label) + " noenhanced\n";
    const double top = panel_top - share * static_cast<double>(j + 1);
    std::snprintf(buf, sizeof buf, "set tmargin at screen %.4f\nset bmargin at screen %.4f\n", top - 0.01,
                  lowest ? bottom_px / h : top - share + 0.01);
    s += buf;
    std::string body_plot = "plot ";
    std::size_t body_model_index = 0;
    for (std::size_t i = 0; i < b.curves.size(); ++i) {
      add_curve(b.curves[i], "$p" + std::to_string(j) + "c" + std::to_string(i), i == 0, body_model_index,
                body_plot);
    }
    if (b.curves.empty()) body_plot += "NaN notitle";
    s += body_plot + "\n";
  }
  if (panel) {
    // The lower panel: no title, no caption (drawn once, with the first plot).
    s += "unset title\nunset label\nset format x '% h'\nset xlabel 'time (s)'\n"
         "set ylabel 'table accel. (m/s^2)' noenhanced\nset offsets 0, 0, graph 0.05, graph 0.05\n"
         "set key inside top right\n";
    const double table_top = body_panels_.empty() ? panel_split : panel_top - share * static_cast<double>(1 + body_panels_.size());
    std::snprintf(buf, sizeof buf, "set tmargin at screen %.4f\nset bmargin at screen %.4f\n",
                  table_top - 0.01, bottom_px / h);
    s += buf;
    s += "$table << EOD\n";
    for (std::size_t k = 0; k < table_time_s_.size(); ++k) {
      AppendNumber(s, table_time_s_[k]);
      s += ' ';
      AppendNumber(s, table_accel_mps2_[k]);
      s += '\n';
    }
    s += "EOD\n";
    s += "plot $table using 1:2 with lines lw 1.0 lc rgb '#555555' dt 1 "
         "title 'table acceleration (RL_TABLE)' noenhanced\n";
  }
  if (multi) s += "unset multiplot\n";
  s += "set output\n";
  return s;
}

std::string ThetaFigure::Write(const std::string& out_path, FigureFormat format, int width_px,
                               int height_px) const {
  if (curves_.empty()) throw std::invalid_argument("the figure has no curve");
  if (width_px < 200 || height_px < 200) {
    throw std::invalid_argument("figure size must be at least 200x200 px, got " +
                                std::to_string(width_px) + "x" + std::to_string(height_px));
  }
  const int min_height_px = Layout(format, caption_.size(), has_table_panel(), body_panels_.size()).min_height_px();
  if (height_px < min_height_px) {
    throw std::invalid_argument("a figure with " + std::to_string(caption_.size()) +
                                " caption lines must be at least " +
                                std::to_string(min_height_px) + " px high, got " +
                                std::to_string(height_px));
  }
  return RunGnuplot(
      gnuplot_, [&](const std::string& output) { return Script(output, format, width_px, height_px); },
      out_path, provenance_);
}

std::string RunGnuplot(const std::string& gnuplot,
                       const std::function<std::string(const std::string& output)>& script_for,
                       const std::string& out_path,
                       const std::vector<std::pair<std::string, std::string>>& provenance) {
  std::error_code ignored;
  std::unique_ptr<common::AtomicFile> created;
  try {
    created = std::make_unique<common::AtomicFile>(out_path);  // empty: only gnuplot can make it non-empty
  } catch (const std::runtime_error& e) {
    throw FigureError(std::string("cannot draw '") + out_path + "': " + e.what());
  }
  common::AtomicFile& output = *created;
  const std::string script = script_for(output.path());

  int in_pipe[2], err_pipe[2];
  if (pipe2(in_pipe, O_CLOEXEC) != 0) throw FigureError(std::string("pipe: ") + std::strerror(errno));
  Fd in_read(in_pipe[0]), in_write(in_pipe[1]);
  if (pipe2(err_pipe, O_CLOEXEC) != 0) throw FigureError(std::string("pipe: ") + std::strerror(errno));
  Fd err_read(err_pipe[0]), err_write(err_pipe[1]);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in_read.get(), 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, err_write.get(), 2);
  std::string program = gnuplot;
  char* argv[] = {program.data(), nullptr};
  pid_t pid = -1;
  const int spawn_error = posix_spawnp(&pid, program.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  in_read.Close();
  err_write.Close();
  if (spawn_error == ENOENT) {
    throw FigureError("cannot draw '" + out_path + "': gnuplot not found ('" + gnuplot +
                      "'); install the Debian package gnuplot-nox (tools/setup.sh does)");
  }
  if (spawn_error != 0) {
    throw FigureError("cannot draw '" + out_path + "': cannot start '" + gnuplot +
                      "': " + std::strerror(spawn_error));
  }

  // gnuplot's stderr is read while the script is written, so neither side
  // can block the other; only its first 64 KiB are kept.
  std::string err;
  std::thread reader([&err, fd = err_read.get()] {
    char chunk[4096];
    for (;;) {
      const ssize_t n = ::read(fd, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      if (err.size() < 65536) err.append(chunk, static_cast<std::size_t>(n));
    }
  });
  const bool written = WriteAll(in_write.get(), script);
  in_write.Close();  // end of the script: gnuplot finishes and exits
  reader.join();
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }

  if (WIFSIGNALED(status)) {
    throw FigureError("cannot draw '" + out_path + "': gnuplot was killed by signal " +
                      std::to_string(WTERMSIG(status)));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !written) {
    throw FigureError("cannot draw '" + out_path + "': gnuplot failed (exit " +
                      std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                      "): " + Complaint(err));
  }
  const auto size = std::filesystem::file_size(output.path(), ignored);
  if (ignored || size == 0) {
    throw FigureError("cannot draw '" + out_path + "': gnuplot exited 0 but wrote no file");
  }
  try {
    if (!provenance.empty()) common::AddProvenanceToFigure(output.path(), provenance);
    output.Commit();
  } catch (const std::runtime_error& e) {
    throw FigureError(std::string("cannot draw '") + out_path + "': " + e.what());
  }
  return Warnings(err);
}

}  // namespace rocklab::report
