#include "gyrotc/algorithms/fit/compensator.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace gyrotc::fit {

Compensator::Compensator(BiasModel model, double scale_mv_per_dps, double die_lag_s)
    : model_(std::move(model)), scale_mv_per_dps_(scale_mv_per_dps), die_lag_s_(die_lag_s) {
  if (!std::isfinite(scale_mv_per_dps) || !(scale_mv_per_dps > 0.0)) {
    throw std::invalid_argument("scale_mv_per_dps must be a positive number");
  }
  if (!std::isfinite(die_lag_s) || die_lag_s < 0.0) {
    throw std::invalid_argument("die_lag_s must be zero or a positive number");
  }
}

Compensated Compensator::compensate(double gyro_mv, double temp_c) const noexcept {
  if (!std::isfinite(temp_c)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, true};
  }
  const bool clamped = temp_c < model_.t_min_c() || temp_c > model_.t_max_c();
  const double bias = model_.bias_mv(temp_c);
  return {(gyro_mv - bias) / scale_mv_per_dps_, bias, clamped};
}

}  // namespace gyrotc::fit
