#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/result.hpp"
#include "gyrotc/hal/temperature_sensor.hpp"
#include "gyrotc/hal/w1_device.hpp"

namespace gyrotc::hal {

// Dallas/Maxim CRC8 (polynomial x^8 + x^5 + x^4 + 1, reflected 0x8C, init 0):
// over the 9 scratchpad bytes it is 0 when the 9th byte is the right CRC.
std::uint8_t crc8_maxim(std::span<const std::uint8_t> bytes) noexcept;

// The w1_slave file of the w1_therm driver, parsed.
struct W1Slave {
  std::array<std::uint8_t, 9> scratchpad{};
  bool kernel_crc_ok = false;   // "crc=.. YES"
  std::int32_t t_milli_c = 0;   // "t=<millidegrees>"
};

Result<W1Slave> parse_w1_slave(std::string_view text) noexcept;
// The `temperature` file: one integer in millidegrees.
Result<std::int32_t> parse_temperature_file(std::string_view text) noexcept;

struct Ds18b20Options {
  W1File source = W1File::w1_slave;  // w1_slave carries the scratchpad for our own CRC check
  // An unchanged value for longer than this is a stuck sensor; 0 turns the
  // check off (a well-controlled casing can sit on one 1/16 C step for long).
  double stuck_after_s = 0.0;
  double min_c = -55.0;   // DS18B20 datasheet operating range
  double max_c = 125.0;
};

// DS18B20 through the w1_therm files. read() reads the file once and checks
// it: our own CRC8, the all-zero scratchpad (a bus held low, which passes a
// naive CRC), the 12-bit resolution (the scratchpad's configuration byte; with
// the temperature file, w1_therm's resolution file once), the 85.000 C
// power-on value (accepted only right after a reading near 85 C), range, and
// a stuck value.
class Ds18b20 final : public TemperatureSensor {
 public:
  static constexpr std::int32_t kPowerOnMilliC = 85'000;  // datasheet: scratchpad after power-on
  static constexpr double kNear85C = 5.0;  // a previous reading this close makes 85.000 C plausible
  static constexpr int kResolutionBits = 12;  // datasheet: 750 ms conversion, 0.0625 C steps

  Ds18b20(W1Device& device, Clock& clock, const Ds18b20Options& options);

  // Checks one file's text read at time_s (what read() does after reading).
  TemperatureReading evaluate(std::string_view text, double time_s) noexcept;

 private:
  TemperatureReading do_read() override;
  std::string_view do_name() const noexcept override { return device_.name(); }
  TemperatureReading accept(std::int32_t milli_c, double time_s) noexcept;

  W1Device& device_;
  Clock& clock_;
  Ds18b20Options options_;
  bool have_previous_ = false;
  std::int32_t previous_milli_c_ = 0;
  double unchanged_since_s_ = 0.0;
  bool resolution_checked_ = false;  // source = temperature: the resolution file was read
};

}  // namespace gyrotc::hal
