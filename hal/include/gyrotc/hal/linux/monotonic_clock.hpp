#pragma once

#include "gyrotc/hal/clock.hpp"

namespace gyrotc::hal {

// CLOCK_MONOTONIC; sleep_until is clock_nanosleep(TIMER_ABSTIME), retried
// on EINTR.
class MonotonicClock final : public Clock {
 private:
  double do_now_s() const noexcept override;
  void do_sleep_until(double t_s) noexcept override;
};

}  // namespace gyrotc::hal
