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
  explicit ProgressPrinter(std::FILE* out);
  // `done` of `total` units of `stage`; done == total ends the stage.
  void Update(const std::string& stage, int done, int total);

 private:
  std::FILE* out_;
  bool tty_;
  std::string stage_;
  std::chrono::steady_clock::time_point stage_start_;
};

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_PROGRESS_H_
