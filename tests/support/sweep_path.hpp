#pragma once

#include <cmath>
#include <span>

namespace gyrotc::test {

// One leg of a test's sweep: a ramp to to_c, then a hold of hold_s.
struct SweepLeg {
  double to_c;
  double hold_s;
};

// The casing of a test's sweep at time t: start_c for rest_s, then each leg
// in turn at rate_c_per_s, and the last leg's temperature after them.
// direction (when given): +1 on a ramp up, -1 on a ramp down, 0 at rest.
inline double sweep_casing_c(double t, double start_c, double rest_s, std::span<const SweepLeg> legs,
                             double rate_c_per_s, double* direction = nullptr) {
  double c = start_c;
  double start = rest_s;
  if (direction != nullptr) *direction = 0.0;
  if (t < start) return c;
  for (const SweepLeg& leg : legs) {
    const double ramp_s = std::fabs(leg.to_c - c) / rate_c_per_s;
    const double sign = leg.to_c > c ? 1.0 : -1.0;
    if (t < start + ramp_s) {
      if (direction != nullptr) *direction = sign;
      return c + sign * rate_c_per_s * (t - start);
    }
    start += ramp_s;
    c = leg.to_c;
    if (t < start + leg.hold_s) return c;
    start += leg.hold_s;
  }
  return c;
}

}  // namespace gyrotc::test
