// Every file the host writes goes through here, whole or not at all: the
// bytes go to a temporary file beside the target, are flushed, the close is
// checked, and only then is the temporary renamed over the target. A run
// that fails, runs out of disk or is interrupted leaves the previous file
// as it was, never half a file; and no output may name one of the run's
// inputs. Host only.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

namespace feedid::host {

/// Whether two paths name the same existing file (device and inode).
bool same_file(const std::string& a, const std::string& b);

/// One output file being written. Open it, write(), then commit(); a file
/// destroyed without a successful commit() removes its temporary and
/// leaves the target untouched. A target that exists and is not a regular
/// file (a pipe, /dev/null), or is named under /dev or /proc (/dev/stdout,
/// even redirected to a file), is written in place, every write and the
/// close checked the same way. A symbolic link is replaced through: its
/// target gets the new file, the link stays.
class OutputFile {
 public:
  /// `inputs`: the run's input files; naming one of them is refused.
  explicit OutputFile(std::string path, const std::vector<std::string>& inputs = {});
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  bool ok() const { return error_.empty(); }
  /// "<path>: cannot write: <reason>", or empty.
  const std::string& error() const { return error_; }
  bool write(const char* data, std::size_t n);
  bool write(const std::string& s) { return write(s.data(), s.size()); }
  /// Flushes, closes and renames into place; false with error() set.
  bool commit();

 private:
  void fail(const std::string& why);
  std::string path_, temp_, target_;  ///< target_: what the temporary is renamed to (a link's target)
  std::FILE* f_ = nullptr;
  std::string error_;
};

/// The file a commit to `path` replaces: a symbolic link's target (the
/// link stays), `path` itself otherwise; "" for a stream's name under /dev
/// or /proc, which is written in place and replaces nothing.
std::string replaced_file(const std::string& path);

/// `content` to `path` through an OutputFile; empty string, or the error.
std::string write_whole_file(const std::string& path, const std::string& content,
                             const std::vector<std::string>& inputs = {});

}  // namespace feedid::host
