#pragma once
/// How a long run (a dataset made, a dataset matched) tells its caller what happens: messages
/// the caller routes (RunReporter), and a reporter to stderr for programs.
#include <functional>
#include <memory>
#include <string>

#include "gimm/core/progress.hpp"

namespace gimm {

/// What a run says as it goes, for its caller to show: a line of its own (info: a patient
/// made, the export written; warning; error: a patient failed), the run's state (progress:
/// patients done, rate, ETA), and end (the last state was given). The library says what
/// happened; the caller chooses where it goes and how it reads (gimm-dataset prefixes its name
/// and keeps one progress line).
enum class RunMessage { info, warning, error, progress, end };
using RunReporter = std::function<void(RunMessage, const std::string&)>;

/// A reporter to stderr: lines of their own ("warning: ...", "error: ..."), the state on one
/// line (a terminal) or every 30 s (a log). A program puts its name in `prefix` and may reword
/// each message (`words`: e.g. show its flags beside the options named).
inline RunReporter stderr_reporter(bool quiet, const std::string& prefix = "",
                                   std::function<std::string(const std::string&)> words = {}) {
  auto line = std::make_shared<ProgressLine>(quiet);
  return [line, prefix, words](RunMessage kind, const std::string& text) {
    const std::string said = words ? words(text) : text;
    switch (kind) {
      case RunMessage::info:
        line->log(prefix + said);
        break;
      case RunMessage::warning:
        line->log(prefix + "warning: " + said);
        break;
      case RunMessage::error:
        line->log("error: " + prefix + said);
        break;
      case RunMessage::progress:
        line->show(prefix + said);
        break;
      case RunMessage::end:
        line->finish();
        break;
    }
  };
}

}  // namespace gimm
