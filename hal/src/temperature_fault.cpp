#include "gyrotc/hal/temperature_sensor.hpp"

namespace gyrotc::hal {

std::string_view to_string(TempFault fault) {
  switch (fault) {
    case TempFault::none: return "ok";
    case TempFault::crc: return "crc error";
    case TempFault::empty_read: return "empty read";
    case TempFault::missing_device: return "device missing";
    case TempFault::power_on_value: return "85 C power-on value";
    case TempFault::all_zero: return "all-zero scratchpad (bus held low)";
    case TempFault::out_of_range: return "out of range";
    case TempFault::stuck: return "stuck value";
    case TempFault::parse_error: return "unparseable";
    case TempFault::io_error: return "i/o error";
    case TempFault::resolution: return "resolution below 12 bit (write 12 to its resolution file)";
    case TempFault::ambiguous: return "several DS18B20s and no id configured";
  }
  return "unknown";
}

}  // namespace gyrotc::hal
