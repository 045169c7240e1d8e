#pragma once

#include <cstdint>

#include "gyrotc/hal/result.hpp"

// The board-level devices the controller runners use. Each is implemented by
// the chip drivers in hal/chips, over Linux or simulated byte transports.
namespace gyrotc::hal {

// One conversion of the rate ADC (ADS1251).
struct AdcSample {
  std::int32_t code = 0;  // sign-extended 24-bit two's complement
  double gyro_mv = 0.0;   // input voltage, mV
  bool clipped = false;   // at +/- full scale: gyro_mv is a bound, not a value
  double time_s = 0.0;    // monotonic time of the DRDY edge
};

class RateAdc {
 public:
  virtual ~RateAdc() = default;
  // Wait for the next conversion (at most timeout_s) and read it.
  Result<AdcSample> read(double timeout_s) noexcept { return do_read(timeout_s); }

 private:
  virtual Result<AdcSample> do_read(double timeout_s) noexcept = 0;
};

// The analog rate output (AD5060 #1).
class RateDac {
 public:
  virtual ~RateDac() = default;
  // Output volts; clamped to the DAC's 0..Vref range.
  Status write_v(double volts) noexcept { return do_write_v(volts); }
  Status power_down() noexcept { return do_power_down(); }

 private:
  virtual Status do_write_v(double volts) noexcept = 0;
  virtual Status do_power_down() noexcept = 0;
};

// The TEC stage: AD5060 #2 (mid-scale = 0 A) into the OPA548 power amplifier.
// Positive current heats the casing.
class TecDriver {
 public:
  virtual ~TecDriver() = default;
  // Clamped to the configured current limit.
  Status set_current_a(double current_a) noexcept { return do_set_current_a(current_a); }
  Status enable(bool on) noexcept { return do_enable(on); }
  // True while the OPA548 is in thermal shutdown.
  Result<bool> thermal_flag() noexcept { return do_thermal_flag(); }
  // DAC to 0 A first, then disable the OPA548; both are attempted even if the
  // first fails, and the first error is returned.
  Status safe_off() noexcept { return do_safe_off(); }

 private:
  virtual Status do_set_current_a(double current_a) noexcept = 0;
  virtual Status do_enable(bool on) noexcept = 0;
  virtual Result<bool> do_thermal_flag() noexcept = 0;
  virtual Status do_safe_off() noexcept = 0;
};

}  // namespace gyrotc::hal
