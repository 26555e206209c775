// Atomic file output: write to a temporary file beside the target, then rename.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace flapstab {

// Writes `content` to `path` atomically (a failed run leaves no half-written file). Creates parent
// directories. Throws OutputError (core/errors.hpp) naming the path and the system's reason (strerror: "No space
// left on device", "Permission denied", "Read-only file system") on failure; the temporary file is removed.
void write_file_atomic(const std::string& path, const std::string& content);

// Writes a set of files (path, content) as one: every file is first written beside its target under a temporary
// name, and only when all are written are they renamed into place, so a failure (a full disk on the third file)
// leaves none of the new set and the earlier files as they were. The directories are locked (flock on
// DIR/.flapstab.lock) for the commit, so two commands writing into one directory at once do not mix their sets.
// Throws OutputError as write_file_atomic.
void write_files_atomic(const std::vector<std::pair<std::string, std::string>>& files);

// Holds DIR/.flapstab-run.lock (flock, exclusive) for a long run's lifetime: a second run into the same directory
// is refused at once (InputError naming the directory and `key`) instead of interleaving its checkpoints and
// rows with the first one's. The lock ends with the process, so a killed run never leaves a stale lock.
class ExclusiveRun {
 public:
  ExclusiveRun(const std::string& directory, const std::string& key);
  ~ExclusiveRun();
  ExclusiveRun(const ExclusiveRun&) = delete;
  ExclusiveRun& operator=(const ExclusiveRun&) = delete;

 private:
  int fd_ = -1;
};

// An exclusive lock on a file (flock), held for the object's lifetime and released when the process ends, however
// it ends (a killed holder never leaves a stale lock). The processes of a campaign (several copies of one command
// sharing a CFD run cache, docs/user-guide.md "Campaigns") claim runs with it. The lock file is created when
// missing and left in place (removing it would let two processes lock two different files of one name); its text
// names the holder (host, process id, time). flock works on local file systems and on NFS (Linux emulates it with
// byte-range locks); on Lustre it needs the `flock` mount option.
class FileLock {
 public:
  enum class Mode { wait, try_only };
  // Mode::wait blocks until the lock is free; Mode::try_only returns at once (held() says whether it was got).
  // OutputError naming the path when the file cannot be created or locked for another reason.
  FileLock(const std::string& path, Mode mode);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  bool held() const { return held_; }
  const std::string& path() const { return path_; }
  // The holder's text ("host pid N since TIME"), or "" when it cannot be read: for messages while waiting.
  static std::string holder(const std::string& path);

 private:
  std::string path_;
  int fd_ = -1;
  bool held_ = false;
};

// The message of an output failure: "cannot <what> PATH: <strerror(err)>".
std::string output_failure(const std::string& what, const std::string& path, int err);

// Removes temporary files (NAME.tmp.PID) left in `directory` (not recursive) by processes that no longer run;
// returns how many were removed. A live process's temporary files (a concurrent run) are left alone.
int remove_stale_temporaries(const std::string& directory);

}  // namespace flapstab
