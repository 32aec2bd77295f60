#include "client/progress.h"

#include <unistd.h>

namespace mvbrdf::client {

ProgressPrinter::ProgressPrinter(std::FILE* out)
    : out_(out), tty_(isatty(fileno(out)) != 0), stage_start_(std::chrono::steady_clock::now()) {}

void ProgressPrinter::Update(const std::string& stage, int done, int total) {
  const auto now = std::chrono::steady_clock::now();
  // A stage starts where the previous one ended (stages without per-unit
  // progress only report their end).
  if (stage != stage_) stage_ = stage;
  const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
  if (done >= total) {
    std::fprintf(out_, tty_ ? "\r\033[K%-16s done in %.1f s\n" : "%-16s done in %.1f s\n", stage.c_str(), elapsed);
    std::fflush(out_);
    stage_.clear();
    stage_start_ = now;
    return;
  }
  if (!tty_) return;
  if (done > 0) {
    const double eta = elapsed / done * (total - done);
    std::fprintf(out_, "\r\033[K%-16s %d/%d  %.1f s, about %.0f s left", stage.c_str(), done, total, elapsed, eta);
  } else {
    std::fprintf(out_, "\r\033[K%-16s %d/%d", stage.c_str(), done, total);
  }
  std::fflush(out_);
}

}  // namespace mvbrdf::client
