// Atomic file output: temporary file + rename.
#include "core/atomic_write.hpp"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <set>
#include <sys/file.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/errors.hpp"

namespace flapstab {

namespace fs = std::filesystem;

std::string output_failure(const std::string& what, const std::string& path, int err) {
  return "cannot " + what + " " + path + ": " + (err != 0 ? std::strerror(err) : "unknown error");
}

namespace {

void make_parent(const fs::path& target) {
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  if (ec) throw OutputError(output_failure("create directory", target.parent_path().string(), ec.value()));
}

std::string temporary_name(const std::string& path) { return path + ".tmp." + std::to_string(::getpid()); }

// Writes content to tmp (created); OutputError naming `path` on failure, with tmp removed.
void write_temporary(const std::string& tmp, const std::string& path, const std::string& content) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw OutputError(output_failure("write", path, errno));
  auto fail = [&](int err) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw OutputError(output_failure("write", path, err));
  };
  const char* p = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(errno);
    }
    p += n;
    left -= std::size_t(n);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(output_failure("write", path, err));
  }
}

}  // namespace

void write_files_atomic(const std::vector<std::pair<std::string, std::string>>& files) {
  std::set<std::string> dirs;
  for (const auto& [path, content] : files) {
    make_parent(fs::path(path));
    dirs.insert(fs::path(path).parent_path().string());
  }
  // DIR/.flapstab.lock of each directory, in sorted order: two sets never wait on each other.
  std::vector<std::unique_ptr<FileLock>> locks;
  for (const auto& d : dirs)
    locks.push_back(std::make_unique<FileLock>((fs::path(d.empty() ? "." : d) / ".flapstab.lock").string(),
                                               FileLock::Mode::wait));
  std::vector<std::string> written;
  try {
    for (const auto& [path, content] : files) {
      write_temporary(temporary_name(path), path, content);
      written.push_back(temporary_name(path));
    }
  } catch (...) {
    for (const auto& t : written) ::unlink(t.c_str());
    throw;
  }
  for (std::size_t i = 0; i < files.size(); ++i)
    if (::rename(written[i].c_str(), files[i].first.c_str()) != 0) {
      const int err = errno;
      for (std::size_t k = i; k < written.size(); ++k) ::unlink(written[k].c_str());
      throw OutputError(output_failure("rename into place", files[i].first, err));
    }
}

void write_file_atomic(const std::string& path, const std::string& content) {
  const fs::path target(path);
  make_parent(target);
  const std::string tmp = temporary_name(target.string());
  write_temporary(tmp, path, content);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(output_failure("rename into place", path, err));
  }
}

ExclusiveRun::ExclusiveRun(const std::string& directory, const std::string& key) {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) throw OutputError(output_failure("create directory", directory, ec.value()));
  const std::string path = (fs::path(directory) / ".flapstab-run.lock").string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd_ < 0) throw OutputError(output_failure("lock", directory, errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK)
      throw InputError(directory, key, "another flapstab run is writing into this directory",
                       "an output directory no running command uses (wait for it, or give another -o)");
    throw OutputError(output_failure("lock", directory, err));
  }
}

ExclusiveRun::~ExclusiveRun() {
  if (fd_ >= 0) {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
}

FileLock::FileLock(const std::string& path, Mode mode) : path_(path) {
  make_parent(fs::path(path));
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd_ < 0) throw OutputError(output_failure("create the lock file", path, errno));
  const int how = LOCK_EX | (mode == Mode::try_only ? LOCK_NB : 0);
  while (::flock(fd_, how) != 0) {
    const int err = errno;
    if (err == EINTR) continue;
    if (err == EWOULDBLOCK && mode == Mode::try_only) return;
    ::close(fd_);
    fd_ = -1;
    throw OutputError(output_failure("lock", path, err));
  }
  held_ = true;
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  const std::time_t now = std::time(nullptr);
  char when[32] = {};
  std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  const std::string text = std::string(host) + " pid " + std::to_string(::getpid()) + " since " + when + "\n";
  if (::ftruncate(fd_, 0) == 0) {
    [[maybe_unused]] const auto w = ::pwrite(fd_, text.data(), text.size(), 0);
  }
}

FileLock::~FileLock() {
  if (fd_ >= 0) {
    if (held_) ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
}

std::string FileLock::holder(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

int remove_stale_temporaries(const std::string& directory) {
  static const std::regex re(R"(.+\.tmp\.(\d+))");
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return 0;
  int removed = 0;
  for (const auto& e : fs::directory_iterator(directory, ec)) {
    std::smatch m;
    const std::string name = e.path().filename().string();
    if (!std::regex_match(name, m, re)) continue;
    const long pid = std::stol(m[1].str());
    const bool alive = pid == long(::getpid()) || ::kill(pid_t(pid), 0) == 0 || errno == EPERM;
    if (!alive && fs::remove(e.path(), ec)) ++removed;
  }
  return removed;
}

}  // namespace flapstab
