#pragma once

#include <atomic>

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/gpio_line.hpp"

namespace gyrotc::hal {

// OPA548 E/S pin simulator: two GPIO lines onto one pin. es_drive is the
// push-pull output (false = low = disabled; power-on: low); reading it back
// gives the level driven, as a GPIO output does (on the reference board it
// drives E/S through an optocoupler and sees nothing of the pin). es_sense
// reads the pin, which the part pulls low itself in thermal shutdown; it
// follows the pin sense_delay_s late (the board's optocouplers and pull-ups:
// a read right after an enable still sees the disabled pin).
class SimOpa548 {
 public:
  // Told when the drive line changes, on the thread that set it.
  class Listener {
   public:
    virtual ~Listener() = default;
    virtual void on_opa548_drive(bool released) noexcept = 0;
  };

  explicit SimOpa548(Listener* listener = nullptr, const Clock* clock = nullptr, double sense_delay_s = 0.0) noexcept
      : listener_(listener), clock_(clock), sense_delay_s_(sense_delay_s) {}
  SimOpa548(const SimOpa548&) = delete;
  SimOpa548& operator=(const SimOpa548&) = delete;

  GpioLine& es_drive() noexcept { return drive_; }
  GpioLine& es_sense() noexcept { return sense_; }

  bool drive_released() const noexcept { return released_.load(std::memory_order_relaxed); }
  // The die's own thermal shutdown (the SimBoard mirrors the plant's here).
  void set_thermal_shutdown(bool on) noexcept { thermal_.store(on, std::memory_order_relaxed); }
  // Fault injection (any thread): thermal shutdown regardless of the die.
  void inject_thermal_shutdown(bool on) noexcept { injected_.store(on, std::memory_order_relaxed); }
  bool injected_shutdown() const noexcept { return injected_.load(std::memory_order_relaxed); }
  bool in_shutdown() const noexcept {
    return thermal_.load(std::memory_order_relaxed) || injected_.load(std::memory_order_relaxed);
  }
  // The output stage conducts.
  bool output_enabled() const noexcept { return drive_released() && !in_shutdown(); }
  // What es_sense reads now: the pin high, released at least sense_delay_s ago.
  bool sense_high() const noexcept;

 private:
  class Drive final : public GpioLine {
   public:
    explicit Drive(SimOpa548& chip) noexcept : chip_(chip) {}

   private:
    Status do_set(bool high) noexcept override;
    Result<bool> do_get() noexcept override { return chip_.drive_released(); }
    Result<double> do_wait_edge(Edge, double) noexcept override;
    std::string_view do_name() const noexcept override { return "sim:opa548-es-drive"; }
    SimOpa548& chip_;
  };
  class Sense final : public GpioLine {
   public:
    explicit Sense(SimOpa548& chip) noexcept : chip_(chip) {}

   private:
    Status do_set(bool) noexcept override;
    Result<bool> do_get() noexcept override { return chip_.sense_high(); }
    Result<double> do_wait_edge(Edge, double) noexcept override;
    std::string_view do_name() const noexcept override { return "sim:opa548-es-sense"; }
    SimOpa548& chip_;
  };

  Listener* listener_;
  const Clock* clock_;
  double sense_delay_s_;
  std::atomic<double> released_at_s_{0.0};
  Drive drive_{*this};
  Sense sense_{*this};
  std::atomic<bool> released_{false};
  std::atomic<bool> thermal_{false};
  std::atomic<bool> injected_{false};
};

}  // namespace gyrotc::hal
