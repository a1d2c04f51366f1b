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
#include <filesystem>
#include <sstream>
#include <thread>

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
  Layout(FigureFormat format, std::size_t caption_lines)
      : font_pt(format == FigureFormat::kSvg ? 11.0 : 10.0),
        line_px(1.6 * font_pt),
        caption_px(line_px * (static_cast<double>(caption_lines) + 0.5)),
        bottom_px(caption_px + 3.2 * line_px) {}  // tick labels and the x label above
  /// Height the figure needs: the bottom, a plot of 100 px, the title above.
  int min_height_px() const { return static_cast<int>(std::ceil(bottom_px + 100 + 3 * line_px)); }
  double font_pt, line_px, caption_px, bottom_px;
};

}  // namespace

void ThetaFigure::AddCurve(ThetaCurve curve) {
  if (curve.time_s.size() != curve.theta_deg.size()) {
    throw std::invalid_argument("curve '" + curve.title + "': " +
                                std::to_string(curve.time_s.size()) + " times but " +
                                std::to_string(curve.theta_deg.size()) + " angles");
  }
  curves_.push_back(std::move(curve));
}

std::string ThetaFigure::Script(const std::string& out_path, FigureFormat format, int width_px,
                                int height_px) const {
  const Layout layout(format, caption_.size());
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
  s += "set xlabel 'time (s)'\nset ylabel 'theta (degrees)'\n";
  // The key sits inside the top of the plot, over a band the y range keeps
  // free for it: 3 entries a row.
  const std::size_t key_rows = (curves_.size() + 2) / 3;
  std::snprintf(buf, sizeof buf,
                "set grid\nset autoscale xfix\n"
                "set key inside top center horizontal maxcols 3\n"
                "set offsets 0, 0, graph %.2f, graph 0.02\n",
                0.06 + 0.07 * static_cast<double>(key_rows));
  s += buf;
  std::snprintf(buf, sizeof buf, "set bmargin at screen %.4f\n", bottom_px / h);
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
  std::size_t model_index = 0;
  for (std::size_t i = 0; i < curves_.size(); ++i) {
    const ThetaCurve& c = curves_[i];
    const std::string block = "$c" + std::to_string(i);
    s += block + " << EOD\n";
    for (std::size_t k = 0; k < c.time_s.size(); ++k) {
      AppendNumber(s, c.time_s[k]);
      s += ' ';
      AppendNumber(s, c.theta_deg[k]);
      s += '\n';
    }
    if (c.time_s.empty()) s += "NaN NaN\n";
    s += "EOD\n";
    plot += i == 0 ? "" : ", ";
    if (c.reference) {
      plot += block + " using 1:2 with lines lw 1.6 lc rgb '#000000' dt 1";
    } else {
      std::snprintf(buf, sizeof buf, " using 1:2 with lines lw 1.3 lc rgb '%s' dt %zu",
                    kColours[model_index % 8], 2 + model_index % 4);
      plot += block + buf;
      ++model_index;
    }
    plot += " title " + Quoted(c.title) + " noenhanced";
  }
  s += plot + "\nset output\n";
  return s;
}

std::string ThetaFigure::Write(const std::string& out_path, FigureFormat format, int width_px,
                               int height_px) const {
  if (curves_.empty()) throw std::invalid_argument("the figure has no curve");
  if (width_px < 200 || height_px < 200) {
    throw std::invalid_argument("figure size must be at least 200x200 px, got " +
                                std::to_string(width_px) + "x" + std::to_string(height_px));
  }
  const int min_height_px = Layout(format, caption_.size()).min_height_px();
  if (height_px < min_height_px) {
    throw std::invalid_argument("a figure with " + std::to_string(caption_.size()) +
                                " caption lines must be at least " +
                                std::to_string(min_height_px) + " px high, got " +
                                std::to_string(height_px));
  }
  return RunGnuplot(gnuplot_, Script(out_path, format, width_px, height_px), out_path);
}

std::string RunGnuplot(const std::string& gnuplot, const std::string& script, const std::string& out_path) {
  std::error_code ignored;
  std::filesystem::remove(out_path, ignored);  // a stale file must not pass for a new one

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
  const auto size = std::filesystem::file_size(out_path, ignored);
  if (ignored || size == 0) {
    throw FigureError("cannot draw '" + out_path + "': gnuplot exited 0 but wrote no file");
  }
  return Warnings(err);
}

}  // namespace rocklab::report
