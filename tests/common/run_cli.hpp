// Running the flapstab program from a test: its exit status and what it printed.
#pragma once
#include <gtest/gtest.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace flapstab::testing {

struct CliOutput {
  int status;  // exit status; -1 when it did not exit normally
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `flapstab ARGS`, stdout and stderr captured in the test's temporary directory under names starting with `tag` and
// holding the process id: ctest -j runs tests of one file as separate processes at once, and gtest's TempDir is
// shared by all of them (one fixed name let two tests read each other's output).
inline CliOutput run_flapstab(const std::string& args, const std::string& tag) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir());
  const std::string stem = tag + "_" + std::to_string(::getpid());
  const std::filesystem::path out = dir / (stem + "_stdout.txt"), err = dir / (stem + "_stderr.txt");
  const std::string cmd = std::string(FLAPSTAB_BINARY) + " " + args + " > " + out.string() + " 2> " + err.string();
  const int rc = std::system(cmd.c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(out), slurp(err)};
}

}  // namespace flapstab::testing
