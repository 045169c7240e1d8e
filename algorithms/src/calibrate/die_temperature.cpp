#include "gyrotc/algorithms/calibrate/die_temperature.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace gyrotc::calibrate {

void DieTemperature::update(double time_s, double sensor_c, double lag_s) noexcept {
  if (!started_ || !(lag_s > 0.0) || !std::isfinite(lag_s)) {
    die_c_ = sensor_c;
  } else {
    // Exact for the sensor moving linearly from the last reading to this one
    // over dt: on a ramp of slope s the die settles at sensor - lag s, and
    // what is left of the difference decays as exp(-dt / lag).
    const double dt = std::max(0.0, time_s - last_time_s_);
    if (dt > 0.0) {
      const double s = (sensor_c - last_sensor_c_) / dt;
      die_c_ = sensor_c - lag_s * s + (die_c_ - last_sensor_c_ + lag_s * s) * std::exp(-dt / lag_s);
    }
  }
  started_ = true;
  last_time_s_ = std::max(time_s, last_time_s_);
  last_sensor_c_ = sensor_c;
}

std::vector<double> die_temperature_c(std::span<const double> time_s, std::span<const double> sensor_c,
                                      double lag_s) {
  if (time_s.size() != sensor_c.size()) throw std::invalid_argument("die_temperature_c: time and sensor differ in length");
  if (!std::isfinite(lag_s)) throw std::invalid_argument("die_temperature_c: the lag must be finite");
  std::vector<double> die(sensor_c.size(), std::numeric_limits<double>::quiet_NaN());
  DieTemperature estimate;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (i > 0 && time_s[i] < time_s[i - 1]) {
      throw std::invalid_argument("die_temperature_c: time decreases at row " + std::to_string(i));
    }
    if (!std::isfinite(sensor_c[i])) continue;
    estimate.update(time_s[i], sensor_c[i], lag_s);
    die[i] = estimate.die_c();
  }
  return die;
}

}  // namespace gyrotc::calibrate
