#pragma once

#include <signal.h>

namespace gyrotc::app {

// The daemon's signals, taken synchronously: the constructor blocks SIGINT,
// SIGTERM and SIGHUP in the calling thread (every thread started afterwards
// inherits the mask, so none of them is interrupted) and ignores SIGPIPE (a
// closed output pipe is a write error, counted, not a death). The supervising
// thread then collects them with wait(). The destructor restores the mask and
// the SIGPIPE disposition.
class DaemonSignals {
 public:
  enum class Event {
    none,    // the wait ran out
    stop,    // SIGINT or SIGTERM: safe state, flush, exit 0
    reload,  // SIGHUP: reload the calibration file
  };

  DaemonSignals();
  ~DaemonSignals();
  DaemonSignals(const DaemonSignals&) = delete;
  DaemonSignals& operator=(const DaemonSignals&) = delete;

  // Waits at most timeout_s for one of the signals.
  Event wait(double timeout_s) noexcept;
  // The signal number behind the last event other than none.
  int last_signal() const noexcept { return last_signal_; }

 private:
  sigset_t set_{};
  sigset_t previous_mask_{};
  struct sigaction previous_sigpipe_{};
  int last_signal_ = 0;
};

}  // namespace gyrotc::app
