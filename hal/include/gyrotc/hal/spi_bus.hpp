#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

// Clock polarity/phase as in Linux spidev: mode = CPOL << 1 | CPHA.
struct SpiConfig {
  std::uint8_t mode = 0;
  std::uint32_t speed_hz = 1'000'000;
  std::uint8_t bits_per_word = 8;
};

// A full-duplex SPI bus with one chip select: tx and rx have the same length
// and are clocked out/in together. NVI: the public calls are non-virtual.
class SpiBus {
 public:
  virtual ~SpiBus() = default;

  Status configure(const SpiConfig& config) noexcept { return do_configure(config); }
  // rx.size() must equal tx.size().
  Status transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
    return do_transfer(tx, rx);
  }
  // The device path or simulator name, for messages.
  std::string_view name() const noexcept { return do_name(); }

 private:
  virtual Status do_configure(const SpiConfig& config) noexcept = 0;
  virtual Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept = 0;
  virtual std::string_view do_name() const noexcept = 0;
};

}  // namespace gyrotc::hal
