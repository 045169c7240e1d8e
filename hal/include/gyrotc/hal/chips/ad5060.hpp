#pragma once

#include <cstdint>

#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// AD5060 16-bit DAC: a 24-bit frame (6 don't-care bits, PD1 PD0, 16 data bits
// straight binary, MSB first), SYNC active low, SPI mode 1.
// Vout = Vref * code / 65536.
enum class Ad5060PowerDown : std::uint8_t {
  normal = 0,       // PD1 PD0 = 00
  gnd_1k = 1,       // 01: output to GND through 1 kOhm
  gnd_100k = 2,     // 10: output to GND through 100 kOhm
  three_state = 3,  // 11: output open
};

struct Ad5060Config {
  double vref_v = 2.5;
  std::uint32_t spi_speed_hz = 1'000'000;
  Ad5060PowerDown power_down_mode = Ad5060PowerDown::gnd_100k;  // used by power_down()
};

class Ad5060 final : public RateDac {
 public:
  Ad5060(SpiBus& spi, const Ad5060Config& config) noexcept;

  static std::uint32_t frame(std::uint16_t code, Ad5060PowerDown mode) noexcept;
  // Nearest code, clamped to 0..65535.
  static std::uint16_t code_for_v(double volts, double vref_v) noexcept;
  double v_for_code(std::uint16_t code) const noexcept { return config_.vref_v * code / 65536.0; }

  // Sets the bus to mode 1, 8-bit words, the configured speed.
  Status init() noexcept;
  Status write_code(std::uint16_t code) noexcept;
  std::uint16_t last_code() const noexcept { return last_code_; }
  const Ad5060Config& config() const noexcept { return config_; }

 private:
  Status do_write_v(double volts) noexcept override;
  Status do_power_down() noexcept override;
  Status send(std::uint32_t frame) noexcept;

  SpiBus& spi_;
  Ad5060Config config_;
  double codes_per_v_;
  std::uint16_t last_code_ = 0;
};

}  // namespace gyrotc::hal
