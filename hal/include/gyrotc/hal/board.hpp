#pragma once

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/temperature_sensor.hpp"

namespace gyrotc::hal {

// What the controller runners need, whatever is behind it (LinuxBoard or
// SimBoard). The references stay valid as long as the board that made it.
struct Board {
  RateAdc& adc;
  TemperatureSensor& casing_sensor;
  TemperatureSensor* ambient_sensor;  // optional second DS18B20
  RateDac& rate_dac;
  TecDriver& tec;
  Clock& clock;
};

}  // namespace gyrotc::hal
