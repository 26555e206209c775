// Tests for core/atomic_write: content lands whole, directories are created, no temporary is left.
#include <gtest/gtest.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include "core/atomic_write.hpp"

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
  EXPECT_THROW(write_file_atomic("/proc/flapstab_cannot_write/x.txt", "x"), std::runtime_error);
}

}  // namespace
}  // namespace flapstab
