#include "client/progress.h"

#include <unistd.h>

namespace mvbrdf::client {

ProgressPrinter::ProgressPrinter(std::FILE* out, bool timed_done_lines)
    : out_(out),
      tty_(isatty(fileno(out)) != 0),
      timed_done_lines_(timed_done_lines),
      stage_start_(std::chrono::steady_clock::now()) {}

void ProgressPrinter::Line(const std::string& text) {
  std::fprintf(out_, in_place_ ? "\r\033[K%s\n" : "%s\n", text.c_str());
  std::fflush(out_);
  in_place_ = false;
}

void ProgressPrinter::StageDone(const std::string& stage, double seconds) {
  std::fprintf(out_, tty_ ? "\r\033[K%-16s done in %.2f s\n" : "%-16s done in %.2f s\n", stage.c_str(), seconds);
  std::fflush(out_);
  in_place_ = false;
}

void ProgressPrinter::Update(const std::string& stage, int done, int total) {
  const auto now = std::chrono::steady_clock::now();
  // A stage starts where the previous one ended (stages without per-unit
  // progress only report their end).
  if (stage != stage_) stage_ = stage;
  const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
  if (done >= total) {
    if (timed_done_lines_) {
      std::fprintf(out_, tty_ ? "\r\033[K%-16s done in %.1f s\n" : "%-16s done in %.1f s\n", stage.c_str(), elapsed);
    } else if (in_place_) {
      std::fputs("\r\033[K", out_);
    }
    in_place_ = false;
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
  in_place_ = true;
  std::fflush(out_);
}

}  // namespace mvbrdf::client
