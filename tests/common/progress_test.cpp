// The progress bar (common/progress.h): its text, and that it draws only on
// a terminal.
//
// Oracle: the format written in progress.h (share of the bytes, B/s rate by
// powers of 1000, time left = bytes left / rate), worked by hand below; a
// pseudo-terminal (openpty) stands for the user's terminal, a pipe for a
// redirected stderr.
#include "common/progress.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "common/logger_clock.h"
#include "tests/scratch.h"

namespace rocklab::common {
namespace {

std::string Format(std::int64_t done, std::int64_t total, double elapsed, int width = 10) {
  char buf[160];
  const std::size_t n = Progress::Format(buf, sizeof buf, "export", done, total, elapsed, width);
  return std::string(buf, n);
}

TEST(ProgressFormat, ShareRateAndTimeLeft) {
  // 50 MB of 100 MB in 4 s: 12.5 MB/s, 50 MB left -> 4 s.
  EXPECT_EQ(Format(50'000'000, 100'000'000, 4.0), "export   [#####-----]  50%   12.5 MB/s  0:04 left");
  // 1 kB of 3.602 MB in 1 s: 1.0 kB/s, 3601 s left -> h:mm:ss; 3599 s -> m:ss.
  EXPECT_EQ(Format(1'000, 3'602'000, 1.0), "export   [----------]   0%    1.0 kB/s  1:00:01 left");
  EXPECT_EQ(Format(1'000, 3'600'000, 1.0), "export   [----------]   0%    1.0 kB/s  59:59 left");
  // Done: full bar, nothing left.
  EXPECT_EQ(Format(2'000, 2'000, 2.0), "export   [##########] 100%    1.0 kB/s  0:00 left");
  // Nothing read yet: no rate, unknown time left.
  EXPECT_EQ(Format(0, 2'000, 0.5), "export   [----------]   0%" + std::string(14, ' ') + "--:-- left");
  // Unknown size: bytes only.
  EXPECT_EQ(Format(2'500'000, 0, 1.0), "export   2.5 MB read    2.5 MB/s");
}

TEST(ProgressFormat, NeverOverrunsTheBuffer) {
  char small[16];
  const std::size_t n = Progress::Format(small, sizeof small, "export", 5, 10, 1.0, 100);
  EXPECT_EQ(n, sizeof small - 1);
  EXPECT_EQ(small[n], '\0');
}

std::string Drain(int fd) {
  std::string out;
  char buf[512];
  pollfd p{fd, POLLIN, 0};
  while (poll(&p, 1, 50) > 0 && (p.revents & POLLIN)) {
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  return out;
}

TEST(Progress, DrawsOnATerminalAndClearsAtTheEnd) {
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  double between_s = 0;  // between the two updates, measured: a loaded machine may take longer than 100 ms
  {
    Progress p("fit", 1000, false, slave);
    EXPECT_TRUE(p.active());
    const auto first = std::chrono::steady_clock::now();
    p.Update(500);  // the first update draws
    p.Update(600);  // within 100 ms of it: no redraw
    between_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - first).count();
  }
  const std::string out = Drain(master);
  EXPECT_NE(out.find("fit      [##########----------]  50%"), std::string::npos) << out;
  if (between_s < 0.1) {
    EXPECT_EQ(out.find("60%"), std::string::npos) << "redrawn within 100 ms: " << out;
  }
  EXPECT_NE(out.rfind("\r\033[K"), std::string::npos) << "the line is not cleared at the end";
  close(slave);
  close(master);
}

TEST(Progress, SilentOnAPipeAndWithQuiet) {
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  {
    Progress p("fit", 1000, false, fds[1]);
    EXPECT_FALSE(p.active());
    p.Update(500);
  }
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  {
    Progress q("fit", 1000, true, slave);  // --quiet on a terminal
    EXPECT_FALSE(q.active());
    q.Update(500);
  }
  close(fds[1]);
  EXPECT_EQ(Drain(fds[0]), "");
  EXPECT_EQ(Drain(master), "");
  close(fds[0]);
  close(slave);
  close(master);
}

// Oracle: the file's offset is what FileProgress reports: a file read to its
// middle and held there shows 50%. Its thread redraws every 100 ms: the
// test reads the terminal until the line is there (deadline 60 s), never a
// fixed sleep.
TEST(FileProgress, FollowsTheReadPositionOfTheFile) {
  const std::string path = test::ScratchDir("file_progress") + "/input.bin";
  {
    FILE* f = std::fopen(path.c_str(), "wb");
    std::string block(1000, 'x');
    std::fwrite(block.data(), 1, block.size(), f);
    std::fclose(f);
  }
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  const int in = open(path.c_str(), O_RDONLY);
  ASSERT_GE(in, 0);
  char buf[500];
  ASSERT_EQ(read(in, buf, sizeof buf), 500);
  const std::string want = "replay   [##########----------]  50%";
  std::string out;
  {
    FileProgress p("replay", path, false, slave);
    EXPECT_TRUE(p.active());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (out.find(want) == std::string::npos && std::chrono::steady_clock::now() < deadline) out += Drain(master);
  }
  close(in);
  out += Drain(master);
  EXPECT_NE(out.find(want), std::string::npos) << out;
  close(slave);
  close(master);
}

}  // namespace
}  // namespace rocklab::common

namespace rocklab::common {
namespace {

// Oracle: the count form of the line, worked by hand: 120 of 600 rows in
// 40 s with 20 done before the start: 100 rows / 40 s = 2.5 rows/s, 480
// rows left -> 192 s = 3:12.
TEST(ProgressFormat, CountsWithTheirUnit) {
  char buf[160];
  std::size_t n = Progress::Format(buf, sizeof buf, "sweep", 120, 600, 40.0, 10, "rows", 20);
  EXPECT_EQ(std::string(buf, n), "sweep    [##--------]  20%  120/600 rows  2.5 rows/s  3:12 left");
  n = Progress::Format(buf, sizeof buf, "fit", 30, 0, 10.0, 10, "model runs");
  EXPECT_EQ(std::string(buf, n), "fit      30 model runs  3.0 model runs/s");
}

// A log line (a NamedLogger's, on stderr) while the bar is drawn there:
// the bar's line is cleared, the log line written whole, the bar drawn
// again below it. Oracle: the byte order on the terminal.
TEST(Progress, LogLinesGoAboveTheBar) {
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  std::fflush(stderr);
  const int saved = dup(2);
  dup2(slave, 2);
  {
    Progress p("export", 1000, false, 2);
    p.Update(500);
    NamedLogger("progress_test")->warn("a line above the bar");
  }
  dup2(saved, 2);
  close(saved);
  const std::string out = Drain(master);
  const std::size_t bar = out.find("export   [");
  const std::size_t clear = out.find("\r\033[K", bar);
  const std::size_t line = out.find("a line above the bar", clear);
  const std::size_t again = out.find("export   [", line);
  ASSERT_NE(bar, std::string::npos) << out;
  ASSERT_NE(clear, std::string::npos) << out;
  ASSERT_NE(line, std::string::npos) << out;
  EXPECT_NE(again, std::string::npos) << "the bar is not drawn again below the line: " << out;
  EXPECT_NE(out.find('\n', line), std::string::npos);
  close(slave);
  close(master);
}

}  // namespace
}  // namespace rocklab::common
