#include "client/interrupt_cleanup.h"

#include <pthread.h>
#include <unistd.h>

#include <ctime>
#include <system_error>

namespace mvbrdf::client {
namespace {

sigset_t Signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

}  // namespace

InterruptCleanup::InterruptCleanup() {
  const sigset_t set = Signals();
  pthread_sigmask(SIG_BLOCK, &set, &old_mask_);
  watcher_ = std::thread([this] { Watch(); });
}

InterruptCleanup::~InterruptCleanup() {
  stop_ = true;
  watcher_.join();
  pthread_sigmask(SIG_SETMASK, &old_mask_, nullptr);
}

void InterruptCleanup::Remove(const std::filesystem::path& dir) {
  std::lock_guard<std::mutex> lock(mu_);
  dir_ = dir;
}

void InterruptCleanup::Watch() {
  const sigset_t set = Signals();
  const timespec poll = {0, 100 * 1000 * 1000};  // how soon the destructor returns
  while (!stop_) {
    const int sig = sigtimedwait(&set, nullptr, &poll);
    if (sig != SIGINT && sig != SIGTERM) continue;  // timeout or EINTR
    {
      std::lock_guard<std::mutex> lock(mu_);
      // Workers may still be writing into it: a few tries.
      for (int attempt = 0; attempt < 5 && !dir_.empty(); ++attempt) {
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
        if (!ec && !std::filesystem::exists(dir_, ec)) break;
      }
    }
    // End the process as the signal would have.
    signal(sig, SIG_DFL);
    sigset_t one;
    sigemptyset(&one);
    sigaddset(&one, sig);
    pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
    raise(sig);
    _exit(128 + sig);  // not reached
  }
}

}  // namespace mvbrdf::client
