#include "gyrotc/algorithms/calibrate/temperature_bins.hpp"

#include <cmath>
#include <map>
#include <stdexcept>

namespace gyrotc::calibrate {

TemperatureBins bin_by_temperature(std::span<const double> temp_c, std::span<const double> gyro_mv,
                                   double bin_width_c) {
  if (temp_c.size() != gyro_mv.size()) throw std::invalid_argument("temperature bins: columns differ in length");
  if (!(bin_width_c > 0.0)) throw std::invalid_argument("temperature bins: the width must be positive");
  struct Sum {
    double temp = 0.0;
    double gyro = 0.0;
    std::size_t count = 0;
  };
  std::map<long long, Sum> sums;
  for (std::size_t i = 0; i < temp_c.size(); ++i) {
    if (!std::isfinite(temp_c[i])) continue;
    Sum& s = sums[static_cast<long long>(std::floor(temp_c[i] / bin_width_c))];
    s.temp += temp_c[i];
    s.gyro += gyro_mv[i];
    ++s.count;
  }
  TemperatureBins bins;
  for (const auto& [key, s] : sums) {
    bins.temp_c.push_back(s.temp / static_cast<double>(s.count));
    bins.gyro_mv.push_back(s.gyro / static_cast<double>(s.count));
    bins.count.push_back(s.count);
  }
  return bins;
}

}  // namespace gyrotc::calibrate
