// Progress of a long job on the terminal: on a TTY one line per stage that
// updates in place (done/total, elapsed, ETA); otherwise one plain line per
// finished stage, so logs and scripts stay readable.
#ifndef MVBRDF_CLIENT_PROGRESS_H_
#define MVBRDF_CLIENT_PROGRESS_H_

#include <chrono>
#include <cstdio>
#include <string>

namespace mvbrdf::client {

class ProgressPrinter {
 public:
  // `timed_done_lines`: done == total prints "STAGE done in S s" with the time
  // measured here; false leaves the finished lines to StageDone (`run`: the
  // seconds result.json records, issue #20).
  explicit ProgressPrinter(std::FILE* out, bool timed_done_lines = true);
  // `done` of `total` units of `stage`; done == total ends the stage.
  void Update(const std::string& stage, int done, int total);
  // "STAGE done in S s" with the stage's own seconds.
  void StageDone(const std::string& stage, double seconds);
  // Any other line (ends an in-place progress line first).
  void Line(const std::string& text);

 private:
  std::FILE* out_;
  bool tty_;
  bool timed_done_lines_;
  bool in_place_ = false;  // a progress line waits to be overwritten
  std::string stage_;
  std::chrono::steady_clock::time_point stage_start_;
};

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_PROGRESS_H_
