// Input errors that carry the file, the key and what was expected, for messages users can act on.
#pragma once
#include <stdexcept>
#include <string>

namespace flapstab {

// Thrown for any bad user input. what() reads "FILE: key 'KEY': PROBLEM (expected EXPECTED)".
class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string key, std::string problem, std::string expected = {})
      : std::runtime_error(compose(file, key, problem, expected)),
        file_(std::move(file)), key_(std::move(key)) {}
  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }

 private:
  static std::string compose(const std::string& file, const std::string& key,
                             const std::string& problem, const std::string& expected) {
    std::string s = file.empty() ? std::string("input") : file;
    if (!key.empty()) s += ": key '" + key + "'";
    s += ": " + problem;
    if (!expected.empty()) s += " (expected " + expected + ")";
    return s;
  }
  std::string file_, key_;
};

// Thrown when a numerical procedure cannot deliver (trim infeasible, solver failure).
class SolveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown by a model asked not to wait (AeroRunOptions::defer_held) for a run another process is computing (a campaign:
// several copies of one command sharing a run cache); the caller goes on with other runs and asks again later.
class RunHeldElsewhere : public SolveError {
 public:
  using SolveError::SolveError;
};

// Thrown when an output cannot be written (disk full, read-only file system, permission denied): what() names
// the path and the operating system's reason. Whatever the command had written of its set is removed.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown when a run stopped on SIGINT or SIGTERM after saving what it needs to resume (core/interrupt.hpp).
class Interrupted : public std::runtime_error {
 public:
  Interrupted(int signal, const std::string& what) : std::runtime_error(what), signal_(signal) {}
  int signal() const { return signal_; }

 private:
  int signal_;
};

}  // namespace flapstab
