// Temporary directories that SIGINT or SIGTERM must not leave behind (`run`'s
// in-process server state in $TMPDIR/mvbrdf-run-XXXXXX).
#ifndef MVBRDF_CLIENT_INTERRUPT_CLEANUP_H_
#define MVBRDF_CLIENT_INTERRUPT_CLEANUP_H_

#include <signal.h>

#include <atomic>
#include <filesystem>
#include <mutex>
#include <thread>

namespace mvbrdf::client {

// While it lives, SIGINT and SIGTERM are taken by a watcher thread instead of
// ending the process at once: the watcher removes the directory given to
// Remove() (if any), then ends the process by the same signal (default
// action, so the exit status says which). Construct it before any other
// thread starts: threads inherit the blocked signals from the thread that
// creates them, and a thread that does not block them would be killed by
// them directly. One per process; the destructor restores the signal mask
// of the constructing thread.
class InterruptCleanup {
 public:
  InterruptCleanup();
  ~InterruptCleanup();
  InterruptCleanup(const InterruptCleanup&) = delete;
  InterruptCleanup& operator=(const InterruptCleanup&) = delete;

  // The directory to remove on a signal (empty: none). Any thread.
  void Remove(const std::filesystem::path& dir);

 private:
  void Watch();

  sigset_t old_mask_;
  std::mutex mu_;
  std::filesystem::path dir_;  // guarded by mu_
  std::atomic<bool> stop_{false};
  std::thread watcher_;
};

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_INTERRUPT_CLEANUP_H_
