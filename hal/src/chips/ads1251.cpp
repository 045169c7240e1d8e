#include "gyrotc/hal/chips/ads1251.hpp"

#include <array>

namespace gyrotc::hal {

Ads1251::Ads1251(SpiBus& spi, GpioLine& drdy, const Ads1251Config& config) noexcept
    : spi_(spi), drdy_(drdy), config_(config), mv_per_code_(config.vref_v * 1000.0 / 8388608.0) {}

Status Ads1251::validate(const Ads1251Config& config) noexcept {
  if (!(config.fclk_hz > 0.0) || !(config.vref_v > 0.0) || config.spi_speed_hz == 0 ||
      !(config.latency_budget_s >= 0.0)) {
    return Error::make(ErrorCode::invalid_config,
                       "ADS1251: fclk_hz, vref_v, spi_speed_hz must be > 0 and latency_budget_s >= 0");
  }
  const double window_s = kDoutWindowClocks / config.fclk_hz;
  const double transfer_s = 24.0 / config.spi_speed_hz;
  if (config.latency_budget_s + transfer_s > window_s) {
    return Error::make(ErrorCode::invalid_config,
                       "ADS1251: at fclk %.0f Hz the DOUT window is %.1f us, shorter than the latency "
                       "budget %.1f us + 24 bits at %u Hz (%.1f us): reads would mix two conversions; "
                       "lower the ADC clock or raise the SPI speed",
                       config.fclk_hz, window_s * 1e6, config.latency_budget_s * 1e6,
                       config.spi_speed_hz, transfer_s * 1e6);
  }
  return {};
}

Status Ads1251::init() noexcept {
  if (Status s = validate(config_); !s) return s;
  return spi_.configure({.mode = 0, .speed_hz = config_.spi_speed_hz, .bits_per_word = 8});
}

std::int32_t Ads1251::sign_extend_24(std::uint32_t raw) noexcept {
  raw &= 0xFFFFFFu;
  return (raw & 0x800000u) != 0 ? static_cast<std::int32_t>(raw) - 0x1000000
                                : static_cast<std::int32_t>(raw);
}

Result<AdcSample> Ads1251::do_read(double timeout_s) noexcept {
  const Result<double> edge = drdy_.wait_edge(Edge::falling, timeout_s);
  if (!edge) return edge.error();
  static constexpr std::array<std::uint8_t, 3> kZeros{};
  std::array<std::uint8_t, 3> rx{};
  if (Status s = spi_.transfer(kZeros, rx); !s) return s.error();
  AdcSample sample;
  sample.code = sign_extend_24(static_cast<std::uint32_t>(rx[0]) << 16 |
                               static_cast<std::uint32_t>(rx[1]) << 8 | rx[2]);
  sample.clipped = sample.code >= kCodeMax || sample.code <= kCodeMin;
  sample.gyro_mv = code_to_mv(sample.code);
  sample.time_s = *edge;
  return sample;
}

}  // namespace gyrotc::hal
