// Tests for core/atomic_write: content lands whole, directories are created, no temporary is left.
#include <gtest/gtest.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>
#include <csignal>
#include <cstdlib>
#include "core/atomic_write.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

TEST(AtomicWrite, WritesWholeFileAndLeavesNoTemporary) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "flapstab_atomic_test" / "sub";
  fs::remove_all(dir.parent_path());
  write_file_atomic((dir / "a.txt").string(), "hello\n");
  std::ifstream in(dir / "a.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), "hello\n");
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    ++n;
    EXPECT_EQ(e.path().filename(), "a.txt");
  }
  EXPECT_EQ(n, 1);
  EXPECT_THROW(write_file_atomic("/proc/flapstab_cannot_write/x.txt", "x"), OutputError);
}

// A failure names the path and the system's reason (strerror), as an OutputError (exit status 4).
TEST(AtomicWrite, FailureNamesThePathAndTheSystemsReason) {
  try {
    write_file_atomic("/proc/version_flapstab.txt", "x");  // /proc refuses new files whoever runs the test
    ADD_FAILURE() << "expected OutputError";
  } catch (const OutputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/proc/version_flapstab.txt"), std::string::npos) << m;
    EXPECT_TRUE(m.find("No such file") != std::string::npos || m.find("Permission denied") != std::string::npos ||
                m.find("not permitted") != std::string::npos || m.find("Read-only") != std::string::npos)
        << m;
  }
}

// A set whose second file cannot be written leaves none of the set (the first file keeps its earlier content)
// and no temporary file.
TEST(AtomicWrite, ASetIsWrittenWholeOrNotAtAll) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "flapstab_atomic_set";
  fs::remove_all(dir);
  write_file_atomic((dir / "a.txt").string(), "old\n");
  EXPECT_THROW(write_files_atomic({{(dir / "a.txt").string(), "new\n"}, {"/proc/flapstab_cannot_write/b.txt", "b"}}),
               OutputError);
  std::ifstream in(dir / "a.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), "old\n");
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_TRUE(e.path().filename() == "a.txt" || e.path().filename() == ".flapstab.lock") << e.path();
  write_files_atomic({{(dir / "a.txt").string(), "new\n"}, {(dir / "b.txt").string(), "b\n"}});
  std::ifstream in2(dir / "b.txt");
  std::string line;
  std::getline(in2, line);
  EXPECT_EQ(line, "b");
}

// Two processes writing sets into one directory at once: with the directory lock the final set is one process's
// whole set, never a mix (20 files per set, 150 commits each).
TEST(AtomicWrite, ConcurrentSetsDoNotMix) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "flapstab_atomic_concurrent";
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto commit = [&](char tag) {
    for (int round = 0; round < 150; ++round) {
      std::vector<std::pair<std::string, std::string>> set;
      for (int f = 0; f < 20; ++f) {
        std::string name = "f";
        name += std::to_string(f);
        set.emplace_back((dir / name).string(), std::string(1, tag));
      }
      write_files_atomic(set);
    }
  };
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    commit('B');
    std::_Exit(0);
  }
  commit('A');
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  std::string seen;
  for (int f = 0; f < 20; ++f) {
    std::string name = "f";
    name += std::to_string(f);
    std::ifstream in(dir / name);
    seen += char(in.get());
  }
  EXPECT_TRUE(seen == std::string(20, 'A') || seen == std::string(20, 'B')) << seen;
}

// Temporary files of processes that no longer run are removed; a live process's are kept.
TEST(AtomicWrite, StaleTemporariesOfDeadProcessesAreRemoved) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "flapstab_atomic_stale";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "x.h5.tmp.4194305") << "dead";                               // above the default pid_max
  std::ofstream(dir / ("y.csv.tmp." + std::to_string(::getpid()))) << "alive";     // this process
  std::ofstream(dir / "z.csv") << "kept";
  EXPECT_EQ(remove_stale_temporaries(dir.string()), 1);
  EXPECT_FALSE(fs::exists(dir / "x.h5.tmp.4194305"));
  EXPECT_TRUE(fs::exists(dir / ("y.csv.tmp." + std::to_string(::getpid()))));
  EXPECT_TRUE(fs::exists(dir / "z.csv"));
}

// A campaign's claim: a second claimant is refused while the first holds the lock, a waiting one gets it when the
// holder ends (here a child process that dies without releasing anything), and the file names the holder.
TEST(FileLock, OneHolderAtATimeAndReleasedWhenTheHolderEnds) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("flapstab_file_lock_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string path = (dir / "sub" / "run_1.lock").string();
  {
    FileLock a(path, FileLock::Mode::try_only);
    ASSERT_TRUE(a.held());  // the directory is created
    EXPECT_NE(FileLock::holder(path).find("pid " + std::to_string(::getpid())), std::string::npos)
        << FileLock::holder(path);
    const FileLock b(path, FileLock::Mode::try_only);
    EXPECT_FALSE(b.held());
  }
  const FileLock c(path, FileLock::Mode::try_only);
  EXPECT_TRUE(c.held());
  // A child holds it and is killed: the lock is free again, and a waiting claimant gets it.
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  if (child == 0) {
    const FileLock mine((dir / "child.lock").string(), FileLock::Mode::wait);
    [[maybe_unused]] const auto w = ::write(ready[1], "x", 1);
    ::pause();
    std::_Exit(0);
  }
  char x = 0;
  ASSERT_EQ(::read(ready[0], &x, 1), 1);
  EXPECT_FALSE(FileLock((dir / "child.lock").string(), FileLock::Mode::try_only).held());
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  EXPECT_TRUE(FileLock((dir / "child.lock").string(), FileLock::Mode::wait).held());
  ::close(ready[0]);
  ::close(ready[1]);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace flapstab
