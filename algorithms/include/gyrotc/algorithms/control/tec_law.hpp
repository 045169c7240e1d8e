#pragma once

#include <limits>

#include "gyrotc/algorithms/control/pid.hpp"

// The TEC current law the Controller applies every PID period, as pure
// functions so that `gyrotc tune` designs on exactly what runs: the current
// range within the OPA548's rails, and the PID plus feed-forward with the
// anti-windup on the current applied (issue 22).
namespace gyrotc::control {

// The OPA548 stage's output swing: the TEC voltage S dT + I R must stay
// inside the rails, so the current the stage can apply falls as the casing
// gets warmer than the other side of the module:
//   max_a = pos_a - a_per_c * dT,  min_a = neg_a - a_per_c * dT,
// pos_a = (V+ - headroom) / R, neg_a = (V- + headroom) / R, a_per_c = S / R.
// dT is taken as casing - ambient reading (0 without an ambient sensor): the
// shell the module pumps from is not measured, and while heating it is colder
// than the ambient, so the estimate errs on the side of more current (a
// stage that clips a little earlier winds the integral up by that little).
struct RailLimit {
  bool known = false;
  double pos_a = 0.0;
  double neg_a = 0.0;
  double a_per_c = 0.0;
};

struct CurrentRange {
  double min_a = 0.0;
  double max_a = 0.0;
};

// The stuck-sensor check's drive threshold (FailsafeLimits::stuck_min_drive_a)
// for a unit whose largest steady holding current over its rated ambients is
// max_holding_a: a quarter above it and 50 mA more, so that a held casing
// whose reading sits on one DS18B20 step is not taken for a stuck sensor; at
// least 0.5 A, at most the current limit.
double stuck_drive_threshold_a(double max_holding_a, double limit_a) noexcept;

// [out_min, out_max] within the rails at this casing reading and ambient
// reading (NaN: no ambient sensor). Never empty: max_a >= min_a.
CurrentRange applied_range(double out_min, double out_max, const RailLimit& rail, double casing_c,
                           double ambient_c) noexcept;

// Feed-forward from the ambient sensor: a_per_c * (setpoint - ambient), 0
// without an ambient reading (NaN).
double feed_forward_a(double a_per_c, double setpoint_c, double ambient_c) noexcept;

// The ambient the feed-forward answers (issue 35): the ambient reading
// through a first-order lag of lag_s, the time the housing takes to carry a
// change of the ambient to the casing (`gyrotc tune`: the identified shell's
// time constant with the casing held). Without it the feed-forward answers a
// chamber ramp at once, and until the housing follows the casing sees the
// error the feed-forward was meant to prevent, with the opposite sign.
class AmbientLag {
 public:
  // A new reading dt_s after the last one: the lagged ambient moves towards
  // it by 1 - exp(-dt_s / lag_s). The first finite reading starts the lag
  // there; lag_s <= 0 is no lag (the reading itself); a NaN reading is none.
  void update(double reading_c, double dt_s, double lag_s) noexcept;
  // NaN until the first reading.
  double value_c() const noexcept { return value_c_; }

 private:
  double value_c_ = std::numeric_limits<double>::quiet_NaN();
};

// One PID period with a feed-forward ff_a: the PID's share may use what the
// feed-forward leaves of the range (so its saturation and anti-windup refer
// to the current applied), and the sum is clamped to the range.
double pid_current_a(IncrementalPid& pid, double casing_c, double setpoint_c, double ff_a,
                     const CurrentRange& range) noexcept;

}  // namespace gyrotc::control
