#include "output_file.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <sys/stat.h>
#include <unistd.h>

namespace feedid::host {
namespace {

std::string reason(int err) { return std::strerror(err != 0 ? err : EIO); }

/// A temporary name beside `path`, so that the rename stays on one file system.
std::string temporary_beside(const std::string& path) {
  const std::filesystem::path p(path);
  const std::string name = "." + p.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-XXXXXX";
  return (p.parent_path() / name).string();
}

bool is_special(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
}

/// A name for the system's streams (/dev/stdout, /dev/fd/N, /proc/self/fd/N):
/// written in place even where it resolves to a regular file (a redirected
/// stdout), since renaming over it would replace the link, not reach the file.
bool names_a_stream(const std::string& path) {
  return path.rfind("/dev/", 0) == 0 || path.rfind("/proc/", 0) == 0;
}

/// The process's own descriptor a stream's name stands for, or -1:
/// /dev/stdout 1, /dev/stderr 2, /dev/fd/N and /proc/self/fd/N N. Opened
/// by name, a redirected stdout got a second offset at 0 (and was
/// truncated), and the run's own output overwrote what was written there.
int own_descriptor(const std::string& path) {
  if (path == "/dev/stdout") return 1;
  if (path == "/dev/stderr") return 2;
  for (const char* prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    const std::string p(prefix);
    if (path.rfind(p, 0) != 0 || path.size() == p.size()) continue;
    int n = 0;
    for (std::size_t i = p.size(); i < path.size(); ++i) {
      if (path[i] < '0' || path[i] > '9' || n > 100000) return -1;
      n = 10 * n + (path[i] - '0');
    }
    return n;
  }
  return -1;
}

}  // namespace

std::string replaced_file(const std::string& path) {
  if (names_a_stream(path)) return "";
  std::error_code ec;
  if (!std::filesystem::is_symlink(std::filesystem::symlink_status(path, ec))) return path;
  const std::filesystem::path target = std::filesystem::weakly_canonical(path, ec);
  return ec ? path : target.string();
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev &&
         sa.st_ino == sb.st_ino;
}

OutputFile::OutputFile(std::string path, const std::vector<std::string>& inputs) : path_(std::move(path)) {
  for (const std::string& in : inputs)
    if (same_file(path_, in)) {
      error_ = path_ + ": refusing to write an output over the input " + in;
      return;
    }
  if (path_.empty()) {
    error_ = "an output path is empty";
    return;
  }
  errno = 0;
  if (const int fd = own_descriptor(path_); fd >= 0) {
    if (fd == 1) std::fflush(stdout);  // what the run printed before comes first
    if (fd == 2) std::fflush(stderr);
    const int copy = ::dup(fd);
    if (copy >= 0) {
      f_ = ::fdopen(copy, "wb");
      if (f_ == nullptr) ::close(copy);
    }
  } else if (is_special(path_) || names_a_stream(path_)) {
    f_ = std::fopen(path_.c_str(), "wb");
  } else {
    target_ = replaced_file(path_);
    temp_ = temporary_beside(target_);
    const int fd = ::mkstemp(temp_.data());
    if (fd >= 0) {
      ::fchmod(fd, 0644);
      f_ = ::fdopen(fd, "wb");
      if (f_ == nullptr) ::close(fd);
    }
    if (f_ == nullptr) {
      if (fd >= 0) ::unlink(temp_.c_str());
      temp_.clear();
    }
  }
  if (f_ == nullptr) fail(reason(errno));
}

OutputFile::~OutputFile() {
  if (f_ != nullptr) std::fclose(f_);
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void OutputFile::fail(const std::string& why) {
  if (error_.empty()) error_ = path_ + ": cannot write: " + why;
}

bool OutputFile::write(const char* data, std::size_t n) {
  if (!ok()) return false;
  errno = 0;
  if (n > 0 && std::fwrite(data, 1, n, f_) != n) fail(reason(errno));
  return ok();
}

bool OutputFile::commit() {
  if (!ok()) return false;
  errno = 0;
  if (std::fflush(f_) != 0) fail(reason(errno));
  if (ok() && !temp_.empty() && ::fsync(::fileno(f_)) != 0) fail(reason(errno));
  errno = 0;
  const int closed = std::fclose(f_);
  f_ = nullptr;
  if (closed != 0) fail(reason(errno));
  if (ok() && !temp_.empty()) {
    errno = 0;
    if (std::rename(temp_.c_str(), target_.c_str()) != 0) fail(reason(errno));
    else temp_.clear();
  }
  return ok();
}

std::string write_whole_file(const std::string& path, const std::string& content, const std::vector<std::string>& inputs) {
  OutputFile f(path, inputs);
  f.write(content);
  f.commit();
  return f.error();
}

}  // namespace feedid::host
