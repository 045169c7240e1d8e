#pragma once

#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

// OPA548 power op-amp, E/S pin: pulled low = output disabled, released =
// enabled; the part itself pulls E/S low while in thermal shutdown. The board
// drives E/S from a push-pull GPIO (es_drive, high = enabled) through a level
// shifter with a default-off pull-down, and may read the pin on a second GPIO
// (es_sense). Reading the drive line back would only return our own output,
// so without a sense line the thermal state is unknown.
// Disabled until enable(true); the back-ends request es_drive low.
class Opa548 {
 public:
  Opa548(GpioLine& es_drive, GpioLine* es_sense) noexcept : drive_(es_drive), sense_(es_sense) {}

  Status enable(bool on) noexcept;
  bool enabled() const noexcept { return enabled_; }
  // Enabled and E/S low: shutdown; enabled and E/S high: clear; disabled
  // (we hold E/S low) or no sense line: unknown.
  Result<ThermalStatus> thermal_status() noexcept;
  bool has_sense() const noexcept { return sense_ != nullptr; }

 private:
  GpioLine& drive_;
  GpioLine* sense_;
  bool enabled_ = false;
};

}  // namespace gyrotc::hal
