#pragma once

#include <cmath>

namespace gyrotc::test {

// A DS18B20 reading at its 12-bit resolution: 1/16 C steps.
inline double ds18b20_steps_c(double temp_c) { return std::round(temp_c * 16.0) / 16.0; }

}  // namespace gyrotc::test
