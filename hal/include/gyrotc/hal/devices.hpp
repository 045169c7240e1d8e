#pragma once

#include <cstdint>
#include <string_view>

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

// Conversions the rate ADC's driver did not deliver, and why (totals since
// the driver was made).
struct AdcReadStats {
  std::uint64_t late_reads = 0;          // read, but the transfer ended past the DOUT window: dropped
  std::uint64_t spurious_edges = 0;      // falling edges the ADC does not make (noise on the DRDY line)
  std::uint64_t missed_conversions = 0;  // never read: too late to start, or their edges were lost
};

class RateAdc {
 public:
  virtual ~RateAdc() = default;
  // Wait for the next conversion that can be read whole (at most timeout_s)
  // and read it.
  Result<AdcSample> read(double timeout_s) noexcept { return do_read(timeout_s); }
  // Call on the thread that reads.
  AdcReadStats stats() const noexcept { return do_stats(); }

 private:
  virtual Result<AdcSample> do_read(double timeout_s) noexcept = 0;
  virtual AdcReadStats do_stats() const noexcept = 0;
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

// What the OPA548's E/S pin tells about thermal shutdown.
enum class ThermalStatus : std::uint8_t {
  clear,     // enabled, and E/S reads high
  shutdown,  // enabled, and E/S reads low: the part pulls it down in thermal shutdown
  unknown,   // nothing to read: no E/S sense line, or disabled (E/S is held low by us)
};
std::string_view to_string(ThermalStatus status) noexcept;

// The TEC stage: AD5060 #2 (mid-scale = 0 A) into the OPA548 power amplifier.
// Positive current heats the casing.
class TecDriver {
 public:
  virtual ~TecDriver() = default;
  // Clamped to the configured current limit.
  Status set_current_a(double current_a) noexcept { return do_set_current_a(current_a); }
  Status enable(bool on) noexcept { return do_enable(on); }
  // The OPA548's thermal state as its E/S pin shows it now.
  Result<ThermalStatus> thermal_status() noexcept { return do_thermal_status(); }
  // False when the board cannot see E/S at all (no sense line): the status
  // is then always unknown.
  bool senses_thermal() const noexcept { return do_senses_thermal(); }
  // DAC to 0 A first, then disable the OPA548; both are attempted even if the
  // first fails, and the first error is returned.
  Status safe_off() noexcept { return do_safe_off(); }

 private:
  virtual Status do_set_current_a(double current_a) noexcept = 0;
  virtual Status do_enable(bool on) noexcept = 0;
  virtual Result<ThermalStatus> do_thermal_status() noexcept = 0;
  virtual bool do_senses_thermal() const noexcept = 0;
  virtual Status do_safe_off() noexcept = 0;
};

}  // namespace gyrotc::hal
