#include "gyrotc/algorithms/calibrate/die_temperature.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace gyrotc::calibrate {

std::vector<double> die_temperature_c(std::span<const double> time_s, std::span<const double> sensor_c,
                                      double lag_s) {
  if (time_s.size() != sensor_c.size()) throw std::invalid_argument("die_temperature_c: time and sensor differ in length");
  if (!std::isfinite(lag_s)) throw std::invalid_argument("die_temperature_c: the lag must be finite");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> die(sensor_c.size(), nan);
  bool started = false;
  double last_t = 0.0;
  double last_u = 0.0;
  double y = 0.0;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (i > 0 && time_s[i] < time_s[i - 1]) {
      throw std::invalid_argument("die_temperature_c: time decreases at row " + std::to_string(i));
    }
    const double u = sensor_c[i];
    if (!std::isfinite(u)) continue;
    if (lag_s <= 0.0) {
      die[i] = u;
      continue;
    }
    if (!started) {
      started = true;
      y = u;
    } else {
      // Exact for u moving linearly from last_u to u over dt: on a ramp of
      // slope s the die settles at u - lag s, and what is left of the
      // difference decays as exp(-dt / lag).
      const double dt = time_s[i] - last_t;
      if (dt > 0.0) {
        const double s = (u - last_u) / dt;
        y = u - lag_s * s + (y - last_u + lag_s * s) * std::exp(-dt / lag_s);
      }
    }
    last_t = time_s[i];
    last_u = u;
    die[i] = y;
  }
  return die;
}

}  // namespace gyrotc::calibrate
