#pragma once

#include <optional>

namespace gyrotc::hal {

// Raspberry Pi kernels can keep a GPIO output driving at its last level after
// the process that requested it let go (pinctrl-bcm2835's
// persist_gpio_outputs; `dtparam=strict_gpiod` in config.txt turns it off):
// a gyrotc that crashes outside systemd would then leave the OPA548 enabled.
// True when the parameter says outputs persist, false when they return to
// inputs, nullopt on a kernel without it (docs/BOARD-rpi4.md).
inline constexpr const char* kPersistGpioOutputsPath = "/sys/module/pinctrl_bcm2835/parameters/persist_gpio_outputs";
std::optional<bool> gpio_outputs_persist(const char* path = kPersistGpioOutputsPath) noexcept;

}  // namespace gyrotc::hal
