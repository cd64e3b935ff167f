#pragma once
/// A progress line (on stderr unless told otherwise) for long runs (gimm-dataset's patients,
/// gimm-match's pairs). On a terminal it overwrites itself ("\r"), with log lines printed above it;
/// into a file or a pipe (a cluster job's log) it writes whole lines, the first update and then at
/// most one per `interval_s` seconds, and the last state when the run finishes: a log is not one
/// long line of carriage returns.
#include <chrono>
#include <cstdio>
#include <string>
#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

namespace gimm {

inline bool is_terminal(std::FILE* stream) {
#if defined(__unix__) || defined(__APPLE__)
  return isatty(fileno(stream)) != 0;
#else
  return false;
#endif
}

class ProgressLine {
 public:
  explicit ProgressLine(bool quiet, double interval_s = 30.0, std::FILE* out = stderr)
      : quiet_(quiet), terminal_(is_terminal(out)), interval_s_(interval_s), out_(out) {}

  /// A line of its own (a warning, a per-item summary), above the progress line.
  void log(const std::string& text) {
    if (terminal_ && width_ > 0)
      std::fprintf(out_, "\r%-*s\n", width_, text.c_str());
    else
      std::fprintf(out_, "%s\n", text.c_str());
  }

  /// The current state; shown now on a terminal, else when the interval has passed.
  void show(const std::string& text) {
    if (quiet_) return;
    if (terminal_) {
      std::fprintf(out_, "\r%s", text.c_str());
      width_ = static_cast<int>(text.size());
      return;
    }
    const auto now = std::chrono::steady_clock::now();
    pending_ = text;
    if (printed_ && std::chrono::duration<double>(now - last_).count() < interval_s_) return;
    std::fprintf(out_, "%s\n", text.c_str());
    pending_.clear();
    printed_ = true;
    last_ = now;
  }

  /// Ends the line on a terminal; elsewhere writes the last state if it is not written yet.
  void finish() {
    if (quiet_) return;
    if (terminal_)
      std::fprintf(out_, "\n");
    else if (!pending_.empty())
      std::fprintf(out_, "%s\n", pending_.c_str());
    pending_.clear();
  }

 private:
  bool quiet_, terminal_;
  double interval_s_;
  std::FILE* out_;
  int width_ = 0;
  bool printed_ = false;
  std::string pending_;
  std::chrono::steady_clock::time_point last_{};
};

}  // namespace gimm
