#pragma once

#include "gyrotc/hal/clock.hpp"

namespace gyrotc::hal {

// Told whenever a simulated clock has moved forward (the SimBoard steps its
// plant from here). Called on the thread that moved the clock.
class ClockListener {
 public:
  virtual ~ClockListener() = default;
  virtual void on_time_advanced(double now_s) noexcept = 0;
};

// Virtual time for lockstep simulation: now_s() only moves when someone
// sleeps until a later time (a DRDY wait, the runner's advance). Single
// threaded by design.
class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(double start_s = 0.0) noexcept : now_s_(start_s) {}
  void set_listener(ClockListener* listener) noexcept { listener_ = listener; }

 private:
  double do_now_s() const noexcept override { return now_s_; }
  void do_sleep_until(double t_s) noexcept override {
    if (!(t_s > now_s_)) return;
    now_s_ = t_s;
    if (listener_ != nullptr) listener_->on_time_advanced(now_s_);
  }

  double now_s_;
  ClockListener* listener_ = nullptr;
};

// Real time for the simulated board under `gyrotc run`: CLOCK_MONOTONIC
// shifted so that the board starts at 0 s (the plant's time), sleeping with
// clock_nanosleep(TIMER_ABSTIME); the listener is told after each sleep, on
// the sleeping thread (the real-time thread: only it may sleep on this clock).
class RealtimeSimClock final : public Clock {
 public:
  RealtimeSimClock() noexcept;
  void set_listener(ClockListener* listener) noexcept { listener_ = listener; }
  // Seconds of CLOCK_MONOTONIC at board time 0.
  double epoch_s() const noexcept { return epoch_s_; }

 private:
  double do_now_s() const noexcept override;
  void do_sleep_until(double t_s) noexcept override;

  double epoch_s_;
  ClockListener* listener_ = nullptr;
};

}  // namespace gyrotc::hal
