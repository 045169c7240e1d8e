#include "gyrotc/app/daemon/signals.hpp"

#include <pthread.h>

#include <cerrno>
#include <cmath>
#include <ctime>

namespace gyrotc::app {

DaemonSignals::DaemonSignals() {
  sigemptyset(&set_);
  sigaddset(&set_, SIGINT);
  sigaddset(&set_, SIGTERM);
  sigaddset(&set_, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &set_, &previous_mask_);
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  sigaction(SIGPIPE, &ignore, &previous_sigpipe_);
}

DaemonSignals::~DaemonSignals() {
  sigaction(SIGPIPE, &previous_sigpipe_, nullptr);
  pthread_sigmask(SIG_SETMASK, &previous_mask_, nullptr);
}

DaemonSignals::Event DaemonSignals::wait(double timeout_s) noexcept {
  const double clamped_s = timeout_s > 0.0 ? timeout_s : 0.0;
  timespec timeout{};
  timeout.tv_sec = static_cast<time_t>(clamped_s);
  timeout.tv_nsec = static_cast<long>((clamped_s - std::floor(clamped_s)) * 1e9);
  int signal_number = -1;
  do {
    signal_number = sigtimedwait(&set_, nullptr, &timeout);
  } while (signal_number < 0 && errno == EINTR);
  if (signal_number < 0) return Event::none;
  last_signal_ = signal_number;
  return signal_number == SIGHUP ? Event::reload : Event::stop;
}

}  // namespace gyrotc::app
