#include "gyrotc/hal/sim/virtual_clock.hpp"

#include "gyrotc/hal/linux/monotonic_clock.hpp"

namespace gyrotc::hal {

namespace {
const MonotonicClock& monotonic() noexcept {
  static const MonotonicClock clock;
  return clock;
}
}  // namespace

RealtimeSimClock::RealtimeSimClock() noexcept : epoch_s_(monotonic().now_s()) {}

double RealtimeSimClock::do_now_s() const noexcept { return monotonic().now_s() - epoch_s_; }

void RealtimeSimClock::do_sleep_until(double t_s) noexcept {
  MonotonicClock sleeper;
  sleeper.sleep_until(epoch_s_ + t_s);
  if (listener_ != nullptr) listener_->on_time_advanced(now_s());
}

}  // namespace gyrotc::hal
