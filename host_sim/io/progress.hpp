// Progress for long runs on stderr: a live percentage on a terminal, a few
// plain lines in a log. Host only.
#pragma once
#include <cstdio>
#include <string>
#include <unistd.h>

namespace feedid::host {

class Progress {
 public:
  explicit Progress(std::string what) : what_(std::move(what)), tty_(isatty(2) != 0) {}
  void operator()(double fraction) {
    const int pct = static_cast<int>(fraction * 100.0 + 0.5);
    if (tty_) {
      if (pct != last_) std::fprintf(stderr, "\r%s %3d %%", what_.c_str(), pct);
      if (pct >= 100 && last_ < 100) std::fprintf(stderr, "\n");
    } else if (pct / 25 != last_ / 25) {
      std::fprintf(stderr, "%s %d %%\n", what_.c_str(), pct / 25 * 25);
    }
    last_ = pct;
  }

 private:
  std::string what_;
  bool tty_;
  int last_ = -1;
};

/// Progress through a log of unknown length, as the log time read so far:
/// live on a terminal, a line per 10 minutes of log otherwise. done() ends
/// the terminal's line.
class StreamProgress {
 public:
  explicit StreamProgress(std::string what) : what_(std::move(what)), tty_(isatty(2) != 0) {}
  void operator()(double t_s) {
    const long block = static_cast<long>(t_s / kLineEveryS);
    if (tty_) {
      std::fprintf(stderr, "\r%s: %.0f s read", what_.c_str(), t_s);
    } else if (block != last_block_) {
      std::fprintf(stderr, "%s: %.0f s read\n", what_.c_str(), t_s);
      last_block_ = block;
    }
  }
  void done() const {
    if (tty_) std::fprintf(stderr, "\n");
  }

 private:
  static constexpr double kLineEveryS = 600.0;
  std::string what_;
  bool tty_;
  long last_block_ = -1;
};

}  // namespace feedid::host
