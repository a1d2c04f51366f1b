// common/atomic_file.h: a file appears whole under its name or not at all.
//
// Oracle: the contract in atomic_file.h, checked on the folder's listing
// and the files' bytes (nothing computed by the code under test).
#include "common/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>

#include "tests/scratch.h"

namespace rocklab::common {
namespace {

using test::Listing;
using test::Slurp;

TEST(AtomicFile, CommitGivesTheWholeFileAndLeavesNoTemporary) {
  const std::string dir = test::ScratchDir("atomic_commit");
  const std::string target = dir + "/out.csv";
  {
    std::ofstream(target) << "old\n";
  }
  AtomicFile f(target);
  EXPECT_EQ(f.target(), target);
  EXPECT_NE(f.path(), target);
  EXPECT_EQ(f.path().rfind(target + ".tmp-", 0), 0u) << f.path();
  std::fputs("new,content\n", f.stream());
  EXPECT_EQ(Slurp(target), "old\n") << "the target changed before Commit";
  f.Commit();
  EXPECT_TRUE(f.committed());
  EXPECT_EQ(Slurp(target), "new,content\n");
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"out.csv"}));
}

// Issue 34: a killed writer's temporary stayed forever. The next AtomicFile
// of the same target removes those of processes that are gone, and only
// those. Oracle: a child that has exited (its PID is gone), this test's
// parent (alive), another target's leftover, a name without a PID.
TEST(AtomicFile, TheNextWriterRemovesADeadWritersTemporary) {
  const std::string dir = test::ScratchDir("atomic_leftovers");
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  ASSERT_EQ(waitpid(child, nullptr, 0), child);
  const std::string dead = std::to_string(child), alive = std::to_string(getppid());
  for (const std::string& name : {"out.h5.tmp-" + dead + "-abc123", "out.h5.tmp-" + alive + "-abc123",
                                  "other.h5.tmp-" + dead + "-abc123", std::string("out.h5.tmp-abc123")}) {
    std::ofstream(dir + "/" + name) << "torn";
  }
  AtomicFile f(dir + "/out.h5");
  std::fputs("whole", f.stream());
  f.Commit();
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"out.h5", "out.h5.tmp-" + alive + "-abc123",
                                                 "other.h5.tmp-" + dead + "-abc123", "out.h5.tmp-abc123"}));
}

TEST(AtomicFile, DestroyedBeforeCommitLeavesThePreviousFileAndNoTemporary) {
  const std::string dir = test::ScratchDir("atomic_abandon");
  const std::string kept = dir + "/kept.h5", fresh = dir + "/fresh.mat";
  const std::string previous("\x89HDF\r\n\x1a\n previous bytes", 23);
  {
    std::ofstream(kept, std::ios::binary) << previous;
  }
  {
    AtomicFile a(kept);
    std::fputs("half a file", a.stream());
    AtomicFile b(fresh);  // a library writes path() itself
    std::ofstream(b.path(), std::ios::binary) << "half a file";
    EXPECT_EQ(Listing(dir).size(), 3u);  // kept.h5 and the two temporaries
  }
  EXPECT_EQ(Slurp(kept), previous);
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"kept.h5"})) << "no file under the new name, no temporary";
}

TEST(AtomicFile, FinishedButNotCommittedIsStillRemoved) {
  const std::string dir = test::ScratchDir("atomic_finished");
  {
    AtomicFile f(dir + "/x.csv");
    std::fputs("x\n", f.stream());
    f.Finish();
  }
  EXPECT_TRUE(Listing(dir).empty());
}

TEST(AtomicFile, CommitAllRenamesEveryFile) {
  const std::string dir = test::ScratchDir("atomic_all");
  AtomicFile a(dir + "/a.csv"), b(dir + "/b.csv");
  std::fputs("a\n", a.stream());
  std::fputs("b\n", b.stream());
  CommitAll({&a, &b});
  EXPECT_EQ(Slurp(dir + "/a.csv"), "a\n");
  EXPECT_EQ(Slurp(dir + "/b.csv"), "b\n");
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"a.csv", "b.csv"}));
}

TEST(AtomicFile, AMovedFileIsCommittedOnceAndRemovedOnce) {
  const std::string dir = test::ScratchDir("atomic_move");
  {
    AtomicFile a(dir + "/m.csv");
    AtomicFile b(std::move(a));
    std::fputs("m\n", b.stream());
    b.Commit();
  }
  EXPECT_EQ(Slurp(dir + "/m.csv"), "m\n");
  {
    AtomicFile a(dir + "/n.csv");
    AtomicFile b(std::move(a));
  }
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"m.csv"}));
}

TEST(AtomicFile, AMissingFolderThrowsNamingTheTarget) {
  const std::string target = test::ScratchDir("atomic_missing") + "/no/such/folder/out.csv";
  try {
    AtomicFile f(target);
    FAIL() << "created a file in a missing folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, WriteFileAtomicallyReplacesTheWholeFile) {
  const std::string dir = test::ScratchDir("atomic_write");
  WriteFileAtomically(dir + "/s.json", "{\"a\": 1}\n");
  WriteFileAtomically(dir + "/s.json", "{}\n");
  EXPECT_EQ(Slurp(dir + "/s.json"), "{}\n");
  EXPECT_EQ(Listing(dir), (std::set<std::string>{"s.json"}));
}

TEST(AtomicFile, TheTemporaryHasTheModeAPlainCreateWouldGive) {
  // Oracle: open(2) with 0666 under this process's umask, as fopen creates.
  const std::string dir = test::ScratchDir("atomic_mode");
  std::ofstream(dir + "/plain") << "x";
  WriteFileAtomically(dir + "/atomic", "x");
  EXPECT_EQ(std::filesystem::status(dir + "/atomic").permissions(),
            std::filesystem::status(dir + "/plain").permissions());
}

}  // namespace
}  // namespace rocklab::common
