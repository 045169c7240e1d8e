#pragma once

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "gyrotc/algorithms/identify/series_identify.hpp"

// An independent generator of chamber records, to test `gyrotc identify` on
// data it was not tuned on (issue 22). Written separately from
// algorithms/identify/record_generator.cpp (the generator the thresholds were
// chosen on) and sharing nothing with it or with model::GyroEffectState:
//  - its own bias curve (not seed Table 2), slope up to ~1.3 mV/C;
//  - samples every 2 s by default, optionally jittered, with gaps;
//  - a two-node casing: chamber -> shell -> casing (the DS18B20's node);
//  - the DS18B20 reads the casing 0.75 s late (conversion), in 0.0625 C steps;
//  - gyro noise: white plus a Gauss-Markov wander of the bias (correlation
//    time wander_tau_s), the bias instability of a real gyro;
//  - hidden effects implemented here from their physical definitions, and
//    four outside the library of `identify` (a stress relaxation, a periodic
//    disturbance, a step, an even function of the rate).
namespace gyrotc::identify_test {

struct IndependentSpec {
  double duration_s = 6.0 * 3600.0;
  double sample_period_s = 2.0;
  double jitter_s = 0.0;  // sample times uniformly within +/- this of the grid
  double low_c = -30.0;
  double high_c = 70.0;
  double min_ramp_c_per_min = 0.3;  // chamber ramps at random rates in this range
  double max_ramp_c_per_min = 1.5;
  // The chamber's first level after the 20 C hold (NaN: random, as the
  // rest): a record that must pass a temperature early (the relaxation's).
  double first_level_c = std::numeric_limits<double>::quiet_NaN();
  // A chamber programme of its own instead (time_s, level_c), linear between
  // the points and held after the last: a triangle, a staircase.
  std::vector<std::pair<double, double>> programme;
  double shell_tau_s = 600.0;   // chamber -> shell
  double casing_tau_s = 200.0;  // shell -> casing
  double white_mv = 0.15;   // per sample
  double wander_mv = 0.15;  // stationary standard deviation of the wander
  double wander_tau_s = 300.0;
  // Samples inside [start, start + length) are dropped.
  std::vector<std::pair<double, double>> gaps;

  // Hidden effects (0 = off).
  double lag_tau_s = 0.0;            // the die lags the casing (thermal_lag)
  double rate_mv_per_c_per_s = 0.0;  // rate_sensitivity, on the casing's dT/dt
  double hysteresis_mv = 0.0;        // ramp_hysteresis: h tanh(rate / r0)
  double hysteresis_r0_c_per_s = 0.003;
  double warm_up_mv = 0.0;           // warm_up: a exp(-t / tau)
  double warm_up_tau_s = 900.0;
  double drift_mv_per_h = 0.0;       // linear_drift
  double ambient_mv_per_c = 0.0;     // ambient_sensitivity, about 25 C
  // Not in identify's library: after the casing first exceeds 50 C the bias
  // relaxes by this much over 1800 s (package stress relief).
  double relaxation_mv = 0.0;
  // Not in the library either: a periodic disturbance of the bias (say, the
  // lab's air conditioning cycling), amplitude and period.
  double periodic_mv = 0.0;
  double periodic_s = 5400.0;
  // Not in the library: the bias steps by step_mv at step_at_s (a mount
  // shifting, a solder joint giving way).
  double step_mv = 0.0;
  double step_at_s = 3.0 * 3600.0;
  // Not in the library: a bias that follows the square of the casing's rate
  // (a gradient across the package that bends it the same way heating or
  // cooling), in mV per (C/min)^2.
  double rate_squared_mv = 0.0;

  std::uint64_t seed = 1;
};

identify::SeriesRecord make_independent_record(const IndependentSpec& spec);

// Issue 31's record that an earlier version answered none: a 250 s lag with
// an 8 mV / 600 s warm-up on a -30 -> 70 -> -30 C triangle (0.5 C/min, 30 min
// holds, 12.5 h), under 0.4 mV of wander with 200 s correlation.
IndependentSpec lag_and_warm_up_on_a_triangle(std::uint64_t seed);

// Issue 74's record: a 2 mV ramp hysteresis (r0 0.003 C/s) on the same
// -30 -> 70 -> -30 C triangle, one ramp rate (0.5 C/min) and 30 min holds,
// under the default wander (0.15 mV, 300 s).
IndependentSpec hysteresis_on_a_triangle(std::uint64_t seed);

// Issue 74's near-collinear record: 36 C, then 30 <-> 42 C at 0.5 C/min with
// 20 min holds, about 6.5 h, no effect set. On 30..42 C this generator's
// curve has its least curvature (its slope 0.52 mV/C at 36 C changes by a
// quarter across the range), so a lag and a rate sensitivity predict nearly
// the same output there.
IndependentSpec narrow_range(std::uint64_t seed);

}  // namespace gyrotc::identify_test
