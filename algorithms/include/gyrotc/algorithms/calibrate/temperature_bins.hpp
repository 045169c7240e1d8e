#pragma once
// A recording's samples averaged in temperature bins: what `gyrotc fit` and
// `gyrotc calibrate` fit the zero-bias model to, one point per bin.
#include <cstddef>
#include <span>
#include <vector>

namespace gyrotc::calibrate {

struct TemperatureBins {
  std::vector<double> temp_c;   // each bin's mean temperature, ascending
  std::vector<double> gyro_mv;  // each bin's mean output
  std::vector<std::size_t> count;
};

// Samples in bins [k w, (k + 1) w) of their temperature; a sample whose
// temperature is not finite is left out. Throws std::invalid_argument when
// the spans differ in length or the width is not positive.
TemperatureBins bin_by_temperature(std::span<const double> temp_c, std::span<const double> gyro_mv,
                                   double bin_width_c);

}  // namespace gyrotc::calibrate
