#pragma once
// The die's lag behind the casing sensor from the whole sweep record (issue
// 30), for where the passes cannot tell it from a hysteresis
// (up_down_difference.hpp: on a nearly straight curve both split the passes
// alike). Wherever the casing starts, stops or turns, the die catches up
// over a few of its time constants: the gyro's output keeps moving after the
// sensor has stopped, and lags behind it when a ramp begins. A hysteresis, a
// split between the ways the casing moves, steps there instead. So the lag is
// the one that makes the record most nearly one curve of the die's
// temperature (calibrate/die_temperature.hpp) plus such a split:
//
//   gyro = B(die_lag(sensor)) + split/2 * direction + noise
//
// B piecewise linear in the die's temperature (knots every knot_spacing_c),
// direction the casing's rate over the sweep's, within -1..1 (+1 up at the
// sweep's rate, 0 held), the lag found by a search over lags, its standard
// error from the linearised fit under the gyro's white noise and wander
// fitted to the residual (tune/residual_noise.hpp), as the passes' is.
#include <cstddef>
#include <limits>
#include <span>
#include <string>

namespace gyrotc::calibrate {

struct RecordLag {
  bool found = false;
  std::string why_not;  // when not found
  double die_lag_s = std::numeric_limits<double>::quiet_NaN();
  double die_lag_s_std = std::numeric_limits<double>::quiet_NaN();
  double split_mv = std::numeric_limits<double>::quiet_NaN();  // up - down, beside the lag
};

struct RecordLagOptions {
  double rate_window_s = 60.0;        // the casing's rate, as fit's record screen reads it
  double min_rate_c_per_min = 0.1;    // the sweep's rate: the median of the rows faster than this
  double knot_spacing_c = 2.0;        // the curve's knots
  double max_lag_s = 900.0;           // the search's end
  double lag_step_s = 2.0;            // the search's grid, refined to ~0.1 s about its best
  std::size_t rows_per_chunk = 5;     // consecutive rows averaged into one (the noise fit's cost)
  // A lag within this many standard errors of 0 is not found: the record
  // does not show it. Nor is one shorter than min_lag_s: at the search's
  // lower end the estimate is one-sided, and the DS18B20's steps alone read
  // as a lag of a few seconds (on 40 of the test's records with no lag: 1.2-4.5 s
  // on 37, 7.9-12 s on 3, rms z 2.4-3.5); binning by such a lag or by none
  // is nearly the same.
  double min_z = 3.0;
  double min_lag_s = 5.0;
};

// Rows whose sensor or gyro is not finite are left out of the fit (the die's
// estimate carries on over them). Throws std::invalid_argument when the
// spans differ in length or the times decrease.
RecordLag die_lag_from_record(std::span<const double> time_s, std::span<const double> sensor_c,
                              std::span<const double> gyro_mv, const RecordLagOptions& options = {});

}  // namespace gyrotc::calibrate
