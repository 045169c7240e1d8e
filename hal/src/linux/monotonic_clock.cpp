#include "gyrotc/hal/linux/monotonic_clock.hpp"

#include <cerrno>
#include <cmath>
#include <ctime>

namespace gyrotc::hal {

double MonotonicClock::do_now_s() const noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

void MonotonicClock::do_sleep_until(double t_s) noexcept {
  if (!(t_s > 0.0)) return;
  const double whole = std::floor(t_s);
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(whole);
  ts.tv_nsec = static_cast<long>((t_s - whole) * 1e9);
  if (ts.tv_nsec >= 1'000'000'000L) ts.tv_nsec = 999'999'999L;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace gyrotc::hal
