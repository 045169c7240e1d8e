#pragma once
// A calibration's own 95 % bound on its error (issue 73): how far the fitted
// zero-bias curve may lie from the unit's true one, from the record's own
// noise. A bootstrap: a pilot curve taken as the truth, the record's residual
// noise about it redrawn, the record binned and fitted again with the whole
// choice (method, order, smoothing) repeated, and the refits' distance from
// the pilot read at each temperature. The pilot is the candidate the
// cross-validation found best (pilot_options), not the simpler one its
// one-standard-error rule chose, and a smoothing spline as the pilot keeps
// twice its effective parameters (fit_pilot): a bootstrap about a smoothed
// curve does not see what the smoothing takes off the truth (a wiggle it
// flattens), and an undersmoothed pilot carries it (docs/SELFCAL.md).
//
// - A recording (a sweep, a chamber run): the residuals are redrawn in
//   moving blocks of the record's own time order, as long as their
//   autocorrelation asks (stats/block_length.hpp), so the gyro's bias wander
//   keeps its correlation; and where the die's lag was measured each
//   replicate's die follows the sensor through a lag drawn from the
//   measurement's standard error, binned at the measured lag as the record was.
// - A table (one row per soak): the points' residuals, inflated by
//   sqrt(n / (n - dof)) for what the fit absorbed, redrawn one by one.
//
// What it cannot see: an error the noise does not make, e.g. a die's lag that
// a chamber record binned by the sensor cannot measure (docs/SELFCAL.md).
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"

namespace gyrotc::calibrate {

struct BoundOptions {
  double confidence = 0.95;
  int replicates = 200;
  std::uint64_t seed = 1;
  double grid_step_c = 0.5;  // the table's spacing over the calibrated range
  double bin_width_c = 1.0;  // a recording's bins, as the calibration binned it
  // Called after each replicate with (done, of); may be empty.
  std::function<void(int, int)> progress;
};

struct CalibrationBound {
  double confidence = 0.95;
  // The calibrated range (the bins' or the points' extremes) on a grid.
  std::vector<double> temp_c;
  // Per temperature: the error the calibration stays within at that
  // temperature with the confidence (mV).
  std::vector<double> bound_mv;
  // Over the whole range at once: the largest error over the range stays
  // within it with the confidence (mV). The one figure to quote.
  double range_bound_mv = 0.0;
  double block_s = 0.0;       // a recording's resampled block (0: a table, one point at a time)
  double die_lag_s_std = 0.0;  // the lag's standard error each replicate drew from (0: none)
  int replicates = 0;          // refits made (a replicate the method cannot fit is left out)
  int failed = 0;              // replicates the method could not fit
  std::string how;             // one line for the report: what was redrawn
};

// A recording: time_s ascending, the casing sensor's readings and the gyro's
// output per row; binned by the die through die_lag_s (0: the sensor's
// reading) in options.bin_width_c bins and fitted with `method`, which made
// `model`. die_lag_s_std > 0 draws each replicate's lag from N(lag, std).
// Throws std::invalid_argument when the record is too short to bootstrap
// (under 16 finite rows) or every replicate fails to fit.
// `pilot`: the truth of the replicates (pilot_options' fit; the calibration's
// own model where nothing was chosen).
CalibrationBound recording_bound(std::span<const double> time_s, std::span<const double> sensor_c,
                                 std::span<const double> gyro_mv, double die_lag_s, double die_lag_s_std,
                                 const fit::BiasModel& pilot, const fit::MethodOptions& method,
                                 const BoundOptions& options);

// A table of points (temperature, mean output), fitted with `method`; the
// pilot has dof effective parameters.
CalibrationBound table_bound(std::span<const double> temp_c, std::span<const double> gyro_mv, double dof,
                             const fit::BiasModel& pilot, const fit::MethodOptions& method,
                             const BoundOptions& options);

// The options that fit the best candidate of a fit's cross-validated choice
// (the lowest held-out mean square, where the one-standard-error rule took
// the simplest near it): the bound's pilot. Without candidates, `method`.
fit::MethodOptions pilot_options(const fit::MethodFit& fit, const fit::MethodOptions& method);

// The pilot itself: pilot_options' fit to the points, a smoothing spline
// with twice the effective parameters its own choice took (at most the
// points less two). Throws std::invalid_argument as fit_method does.
fit::MethodFit fit_pilot(std::span<const double> temp_c, std::span<const double> gyro_mv, const fit::MethodFit& fit,
                         const fit::MethodOptions& method);

// The per-temperature bound at temp_c, linear between the grid's points and
// the end's value outside them.
double bound_at_mv(const CalibrationBound& bound, double temp_c);

}  // namespace gyrotc::calibrate
