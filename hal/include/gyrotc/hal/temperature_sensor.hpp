#pragma once

#include <cstdint>
#include <string_view>

namespace gyrotc::hal {

// Why a temperature reading is not valid. Typed so the controller's
// fail-safes can tell a CRC glitch from a vanished device.
enum class TempFault : std::uint8_t {
  none = 0,
  crc,             // the w1 driver or our own CRC8 check said NO
  empty_read,      // the sysfs file was empty
  missing_device,  // the device directory is gone
  power_on_value,  // 85.000 C right after power-on (no previous reading near 85 C)
  all_zero,        // all-zero scratchpad: the bus is held low (passes a naive CRC)
  out_of_range,    // outside the DS18B20's -55..+125 C
  stuck,           // unchanged for longer than allowed
  parse_error,     // the file did not have the kernel's format
  io_error,        // any other read failure
  resolution,      // converting at fewer than 12 bits (coarser steps than the loop is tuned for)
  ambiguous,       // no id configured and several DS18B20s on the bus
};

std::string_view to_string(TempFault fault);

// One reading of a temperature sensor. time_s is the monotonic time the
// conversion started (what the value reflects).
struct TemperatureReading {
  double temp_c = 0.0;
  double time_s = 0.0;
  bool valid = false;
  TempFault fault = TempFault::none;
};

// A temperature sensor (DS18B20). read() blocks for a conversion (up to
// 750 ms on real hardware), so it is never called on the real-time thread.
// A failed read is a reading with valid = false and a typed fault.
class TemperatureSensor {
 public:
  virtual ~TemperatureSensor() = default;

  TemperatureReading read() { return do_read(); }
  // Device id or path, for messages.
  std::string_view name() const noexcept { return do_name(); }

 private:
  virtual TemperatureReading do_read() = 0;
  virtual std::string_view do_name() const noexcept = 0;
};

}  // namespace gyrotc::hal
