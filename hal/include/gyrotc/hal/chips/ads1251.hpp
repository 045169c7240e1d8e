#pragma once

#include <cstdint>

#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// ADS1251 24-bit delta-sigma ADC: conversions at fCLK/384; the combined
// DOUT/DRDY line falls when a conversion is ready, and the 24 bits must be
// clocked out (SPI mode 0, MSB first) inside the DOUT window of about
// 348/fCLK, or the data of two conversions mix. Full scale is +/- Vref.
struct Ads1251Config {
  double fclk_hz = 384'000.0;          // 1 kSPS, a 906 us DOUT window
  double vref_v = 2.5;
  std::uint32_t spi_speed_hz = 1'000'000;
  // Worst case from the DRDY edge to the first SCLK (edge event wake-up,
  // scheduling): the configuration is refused if the window cannot hold it
  // plus the 24 clock periods.
  double latency_budget_s = 300e-6;
};

class Ads1251 final : public RateAdc {
 public:
  static constexpr std::int32_t kCodeMax = 0x7FFFFF;   // +full scale
  static constexpr std::int32_t kCodeMin = -0x800000;  // -full scale
  static constexpr double kClocksPerSample = 384.0;    // datasheet: data rate = fCLK/384
  static constexpr double kDoutWindowClocks = 348.0;   // datasheet: DOUT valid ~348 tCLK

  Ads1251(SpiBus& spi, GpioLine& drdy, const Ads1251Config& config) noexcept;

  // Why `config` cannot be read reliably, or success.
  static Status validate(const Ads1251Config& config) noexcept;
  // Validates, then sets the bus to mode 0, 8-bit words, the configured speed.
  Status init() noexcept;

  static std::int32_t sign_extend_24(std::uint32_t raw) noexcept;
  double code_to_mv(std::int32_t code) const noexcept { return code * mv_per_code_; }
  double sample_period_s() const noexcept { return kClocksPerSample / config_.fclk_hz; }
  double dout_window_s() const noexcept { return kDoutWindowClocks / config_.fclk_hz; }
  const Ads1251Config& config() const noexcept { return config_; }

 private:
  Result<AdcSample> do_read(double timeout_s) noexcept override;

  SpiBus& spi_;
  GpioLine& drdy_;
  Ads1251Config config_;
  double mv_per_code_;
};

}  // namespace gyrotc::hal
