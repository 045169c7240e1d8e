#pragma once

#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

// OPA548 power op-amp, E/S pin: pulled low = output disabled, released =
// enabled; the part itself pulls E/S low while in thermal shutdown. The board
// drives E/S from a push-pull GPIO (es_drive, high = enabled) through a level
// shifter with a default-off pull-down, and may read the pin on a second GPIO
// (es_sense); without one the drive line is read back.
// Disabled until enable(true); the back-ends request es_drive low.
class Opa548 {
 public:
  Opa548(GpioLine& es_drive, GpioLine* es_sense) noexcept : drive_(es_drive), sense_(es_sense) {}

  Status enable(bool on) noexcept;
  bool enabled() const noexcept { return enabled_; }
  // True when enabled but E/S reads low: thermal shutdown.
  Result<bool> thermal_flag() noexcept;

 private:
  GpioLine& drive_;
  GpioLine* sense_;
  bool enabled_ = false;
};

}  // namespace gyrotc::hal
