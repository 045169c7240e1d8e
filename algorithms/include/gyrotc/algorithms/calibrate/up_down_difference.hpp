#pragma once
// How the gyro's output differs between the self-calibration's upward and
// downward passes at the same casing temperature (issue 30): the die's lag
// behind the casing sensor shifts the two passes by opposite amounts, and a
// bias with hysteresis adds its own split. The calibration fits their mean;
// the split is what a unit sees when it warms or cools through that
// temperature at the sweep's rate.
//
// The two causes act differently along the curve: the lag's split is the
// rate times the lag times the curve's slope there (up - down =
// -lag (r_up + r_down) B'(T)), a hysteresis's is the same wherever the
// passes cross. So one sweep tells them apart where the slope changes over
// the range (a bowl, an S-curve): fitted against -(r_up + r_down) B'(T) and
// a constant, the splits give the lag as the one's coefficient and the
// hysteresis as the other's. On a straight curve the two are one column; a
// second sweep at another rate would separate them there.
#include <cstddef>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace gyrotc::calibrate {

struct UpDownBin {
  double temp_c = 0.0;  // the bin's centre
  double up_mv = 0.0;   // mean gyro output of the rows moving up
  double down_mv = 0.0;
  std::size_t up_rows = 0;
  std::size_t down_rows = 0;
  double up_rate_c_per_min = 0.0;    // mean |rate| of those rows
  double down_rate_c_per_min = 0.0;
};

// The split taken apart (see above), with standard errors under the gyro's
// white noise and wander as fitted to the fit's own residual (neighbouring
// bins are crossed minutes apart and share the wander).
struct LagAndHysteresis {
  bool separated = false;
  std::string why_not;  // when not separated
  double die_lag_s = std::numeric_limits<double>::quiet_NaN();  // the die's lag behind the casing sensor
  double die_lag_s_std = std::numeric_limits<double>::quiet_NaN();
  // up - down where the curve is flat: a hysteresis, or a response to the
  // rate of change itself (at one rate the two are the same).
  double split_mv = std::numeric_limits<double>::quiet_NaN();
  double split_mv_std = std::numeric_limits<double>::quiet_NaN();
};

struct UpDownDifference {
  std::vector<UpDownBin> bins;  // those crossed both ways, coolest first
  double max_abs_mv = 0.0;      // largest |up - down|
  double max_at_c = 0.0;        // where
  double mean_abs_mv = 0.0;     // mean |up - down| over the bins
  LagAndHysteresis separation;
};

struct UpDownOptions {
  double bin_width_c = 1.0;             // as `fit` bins a record
  double rate_window_s = 60.0;          // the casing's rate, as fit's record screen reads it
  double min_rate_c_per_min = 0.1;      // slower rows (the dwells at the ends) count for neither pass
  std::size_t min_rows_per_pass = 10;   // a bin needs this many rows each way
  // The separation reads only rows that have moved one way this long (the
  // die's lag builds up over ~3 time constants after a turn).
  double pass_settle_s = 300.0;
  double slope_half_width_c = 2.0;      // the slope: a quadratic through the bins' means within this
  std::size_t min_bins_to_separate = 8;
  // Below this spread of the lag's column (its standard deviation over its
  // rms), the slope hardly changes: lag and hysteresis are one column.
  double min_slope_spread = 0.25;
};

UpDownDifference up_down_difference(std::span<const double> time_s, std::span<const double> sensor_c,
                                    std::span<const double> gyro_mv, const UpDownOptions& options = {});

}  // namespace gyrotc::calibrate
