#include "gyrotc/algorithms/control/tec_law.hpp"

#include <algorithm>
#include <cmath>

namespace gyrotc::control {

double stuck_drive_threshold_a(double max_holding_a, double limit_a) noexcept {
  return std::max(0.5, std::min(1.25 * max_holding_a + 0.05, limit_a));
}

CurrentRange applied_range(double out_min, double out_max, const RailLimit& rail, double casing_c,
                           double ambient_c) noexcept {
  CurrentRange r{out_min, out_max};
  if (rail.known) {
    const double dt_c = std::isfinite(ambient_c) ? casing_c - ambient_c : 0.0;
    r.max_a = std::min(r.max_a, rail.pos_a - rail.a_per_c * dt_c);
    r.min_a = std::max(r.min_a, rail.neg_a - rail.a_per_c * dt_c);
  }
  r.max_a = std::max(r.max_a, r.min_a);
  return r;
}

double feed_forward_a(double a_per_c, double setpoint_c, double ambient_c) noexcept {
  return std::isfinite(ambient_c) ? a_per_c * (setpoint_c - ambient_c) : 0.0;
}

void AmbientLag::update(double reading_c, double dt_s, double lag_s) noexcept {
  if (!std::isfinite(reading_c)) return;
  if (!std::isfinite(value_c_) || !(lag_s > 0.0)) {
    value_c_ = reading_c;
    return;
  }
  value_c_ += -std::expm1(-std::max(dt_s, 0.0) / lag_s) * (reading_c - value_c_);
}

double pid_current_a(IncrementalPid& pid, double casing_c, double setpoint_c, double ff_a,
                     const CurrentRange& range) noexcept {
  const double u = pid.step(casing_c, setpoint_c, range.min_a - ff_a, range.max_a - ff_a);
  return std::clamp(u + ff_a, range.min_a, range.max_a);
}

}  // namespace gyrotc::control
