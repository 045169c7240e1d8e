#pragma once

namespace gyrotc::hal {

// A monotonic time source in seconds. The Linux back-end is CLOCK_MONOTONIC;
// the simulated board's is a VirtualClock that only moves when told to.
class Clock {
 public:
  virtual ~Clock() = default;

  double now_s() const noexcept { return do_now_s(); }
  // Return at (or, for a virtual clock, move to) the absolute time t_s.
  void sleep_until(double t_s) noexcept { do_sleep_until(t_s); }

 private:
  virtual double do_now_s() const noexcept = 0;
  virtual void do_sleep_until(double t_s) noexcept = 0;
};

}  // namespace gyrotc::hal
