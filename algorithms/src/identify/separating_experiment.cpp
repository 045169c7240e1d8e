#include "gyrotc/algorithms/identify/separating_experiment.hpp"

#include <cstdio>

namespace gyrotc::identify {

namespace {

bool is_pair(const std::string& a, const std::string& b, const char* x, const char* y) {
  return (a == x && b == y) || (a == y && b == x);
}

bool is_thermal(const std::string& e) {
  return e == "thermal_lag" || e == "rate_sensitivity" || e == "ramp_hysteresis" || e == "ambient_sensitivity";
}

std::string range_of(const RecordCoverage& r) {
  char text[64];
  std::snprintf(text, sizeof text, "%.1f..%.1f C", r.low_c, r.high_c);
  return text;
}

}  // namespace

std::string separating_experiment(const std::string& a, const std::string& b, const RecordCoverage& r) {
  char text[512];
  // A lag's error is the bias curve's slope times the lag's temperature
  // difference (-tau f'(T) dT/dt on a ramp), a rate sensitivity's is k dT/dt
  // whatever the slope; and after a ramp stops the lag's decays over tau.
  if (is_pair(a, b, "thermal_lag", "rate_sensitivity")) {
    return "a record over a wider range (this one spans " + range_of(r) +
           "), where the bias curve's slope changes: a lag's error follows the slope, a rate sensitivity's does "
           "not; or fast steps held for several minutes: a lag's error decays over its time constant after the "
           "ramp ends, a rate sensitivity's ends with it";
  }
  // A hysteresis saturates with the rate (h tanh(rate / r0)); a rate
  // sensitivity, and a lag's error, grow in proportion to it.
  if (is_pair(a, b, "ramp_hysteresis", "rate_sensitivity") || is_pair(a, b, "ramp_hysteresis", "thermal_lag")) {
    const char* other = a == "ramp_hysteresis" ? b.c_str() : a.c_str();
    if (r.ramp_fast_c_per_min > 0.0) {
      std::snprintf(text, sizeof text,
                    "ramps at two rates at least 3x apart (this record's: %.2g..%.2g C/min): a hysteresis "
                    "saturates with the rate, %s grows in proportion to it",
                    r.ramp_slow_c_per_min, r.ramp_fast_c_per_min, other);
    } else {
      std::snprintf(text, sizeof text,
                    "ramps at two rates at least 3x apart: a hysteresis saturates with the rate, %s grows in "
                    "proportion to it",
                    other);
    }
    return text;
  }
  // An ambient sensitivity follows the room; the others follow the casing,
  // whose rate on a chamber record is the room's difference through the
  // casing's lag. Moving the casing with the room held breaks that.
  if ((a == "ambient_sensitivity" && is_thermal(b)) || (b == "ambient_sensitivity" && is_thermal(a))) {
    return "TEC steps with the chamber held (the casing moves, the room does not), or holds long enough for the "
           "casing to settle at each chamber temperature: an ambient sensitivity follows the room, the other the "
           "casing";
  }
  // A warm-up settles within a few time constants of power-on, a drift goes
  // on for as long as the record does.
  if (is_pair(a, b, "warm_up", "linear_drift")) {
    std::snprintf(text, sizeof text,
                  "a longer record (this one: %.1f h), or a second power-on: a warm-up settles within a few of its "
                  "time constants and repeats after a power-on, a drift goes on and does not",
                  r.duration_s / 3600.0);
    return text;
  }
  if ((a == "warm_up" && is_thermal(b)) || (b == "warm_up" && is_thermal(a))) {
    return "the chamber held for the first hour after power-on: a warm-up shows there, an effect of the "
           "temperature's changes does not";
  }
  if ((a == "linear_drift" && is_thermal(b)) || (b == "linear_drift" && is_thermal(a))) {
    return "the record ends where it began, at a temperature held for long enough to settle: a drift shows as a "
           "difference there, an effect of the temperature's changes does not";
  }
  // Gas desorption grows with an Arrhenius factor; a parallel loss path is
  // a constant 1/Q term.
  if (is_pair(a, b, "gas_desorption", "parallel_loss")) {
    return "more table points at the hot end and beyond it (this table spans " + range_of(r) +
           "): gas desorption grows with an Arrhenius factor there, a parallel loss path stays constant";
  }
  return "";
}

std::string alternative_line(const Alternative& a) {
  char alike[96];
  std::snprintf(alike, sizeof alike, " (fitted contributions correlate %.3f over the record)", a.correlation);
  std::string line = a.told_apart ? a.effect + ", not " + a.other + alike + ": the record told them apart"
                                  : a.effect + " or " + a.other + alike + ": the record cannot tell them apart";
  if (!a.told_apart && !a.experiment.empty()) line += "; what would: " + a.experiment;
  return line;
}

}  // namespace gyrotc::identify
