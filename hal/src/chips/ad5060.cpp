#include "gyrotc/hal/chips/ad5060.hpp"

#include <array>
#include <cmath>

namespace gyrotc::hal {

Ad5060::Ad5060(SpiBus& spi, const Ad5060Config& config) noexcept
    : spi_(spi), config_(config), codes_per_v_(65536.0 / config.vref_v) {}

namespace {
std::uint16_t nearest_code(double code) noexcept {
  if (!(code > 0.0)) return 0;  // also NaN
  if (code >= 65535.0) return 65535;
  return static_cast<std::uint16_t>(code + 0.5);  // nearest (cheaper than nearbyint per sample)
}
}  // namespace

std::uint32_t Ad5060::frame(std::uint16_t code, Ad5060PowerDown mode) noexcept {
  return static_cast<std::uint32_t>(mode) << 16 | code;
}

std::uint16_t Ad5060::code_for_v(double volts, double vref_v) noexcept {
  return nearest_code(volts / vref_v * 65536.0);
}

Status Ad5060::init() noexcept {
  if (!(config_.vref_v > 0.0) || config_.spi_speed_hz == 0) {
    return Error::make(ErrorCode::invalid_config, "AD5060 on %.*s: vref_v and spi_speed_hz must be > 0",
                       static_cast<int>(spi_.name().size()), spi_.name().data());
  }
  return spi_.configure({.mode = 1, .speed_hz = config_.spi_speed_hz, .bits_per_word = 8});
}

Status Ad5060::send(std::uint32_t word) noexcept {
  const std::array<std::uint8_t, 3> tx{static_cast<std::uint8_t>(word >> 16),
                                       static_cast<std::uint8_t>(word >> 8),
                                       static_cast<std::uint8_t>(word)};
  std::array<std::uint8_t, 3> rx{};
  return spi_.transfer(tx, rx);
}

Status Ad5060::write_code(std::uint16_t code) noexcept {
  Status s = send(frame(code, Ad5060PowerDown::normal));
  if (s) last_code_ = code;
  return s;
}

Status Ad5060::do_write_v(double volts) noexcept { return write_code(nearest_code(volts * codes_per_v_)); }

Status Ad5060::do_power_down() noexcept { return send(frame(last_code_, config_.power_down_mode)); }

}  // namespace gyrotc::hal
