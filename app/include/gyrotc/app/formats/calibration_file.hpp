#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::app {

// Where a calibration came from: written to the file's [source] table for
// people to read; the loader does not need it.
struct CalibrationSource {
  std::string data;       // input file
  std::string method;     // poly | piecewise | spline | smooth | bpnn | paper | auto
  std::string structure;  // e.g. "orders 5/5/4, breakpoints -7.5, 52.5 C"
  std::size_t points = 0;
  double in_sample_max_abs_dps = 0.0;
  double in_sample_rms_dps = 0.0;
  double loo_max_abs_dps = 0.0;
  double loo_rms_dps = 0.0;
  // The whole choice repeated in every fold (written when computed).
  std::optional<double> nested_loo_max_abs_dps;
  std::optional<double> nested_loo_rms_dps;
  // The record checks `fit --accept` overrode, "check: reason" each.
  std::vector<std::string> accepted;
};

// The calibration's own bound on its error (issue 73; calibrate/calibration_bound.hpp):
// how far the curve may lie from the unit's true one, from the record's noise.
struct CalibrationErrorBound {
  double confidence = 0.95;     // key confidence
  double range_dps = 0.0;       // key range_dps: the largest error over the grid, all at once
  std::vector<double> temp_c;   // key c: the grid over the calibrated range, ascending
  std::vector<double> dps;      // key dps: each temperature's own bound
  std::string how;              // key how: how it was computed, for people (optional)

  double lo_c() const { return temp_c.front(); }
  double hi_c() const { return temp_c.back(); }
};

struct Calibration {
  fit::BiasModel model;
  double scale_mv_per_dps;  // key scale_mv_per_dps; 8.774 (seed Table 2) when absent
  // key die_lag_s; 0 when absent: the model is of the casing sensor's reading
  double die_lag_s = 0.0;
  std::optional<CalibrationErrorBound> bound;  // table [bound]; absent in files written before it
};

// Calibration file (TOML), version 1:
//   format = "gyrotc-calibration", version = 1
//   kind = "polynomial" | "piecewise" | "spline" | "bp_network" | "paper_reference"
//   range_c = [t_min, t_max]          (not for paper_reference)
//   scale_mv_per_dps = 8.774          (optional)
//   die_lag_s = 42.2                  (optional, 0..3600 s; 0 when absent) the model is of the
//       die's temperature, the casing sensor through a first-order lag of this length (a
//       record binned by the die, `fit --die-lag-s`, `calibrate`): the Controller compensates
//       at the die's temperature estimated so (calibrate/die_temperature.hpp DieTemperature)
//   [polynomial] center_c, scale_c, coefficients_mv = [a0, a1, ...]
//   [piecewise] breakpoints_c = [...]; [[piecewise.segment]] center_c, scale_c, coefficients_mv
//   [spline] knots_c = [x0, x1, ...] (ascending, inside range_c), values_mv = [y0, ...],
//       second_derivatives = [m0, ...] (mV/C^2), one of each per knot: on [x_i, x_i+1], with
//       h = x_i+1 - x_i, a = (x_i+1 - T) / h, b = 1 - a,
//       bias_mv = a y_i + b y_i+1 + ((a^3 - a) m_i + (b^3 - b) m_i+1) h^2 / 6
//       (written by `gyrotc fit --method spline|smooth|auto`; the end cubics continue up to range_c)
//   [bp_network] out_center_mv, out_half_range_mv; [[bp_network.layer]] inputs, outputs,
//       activation ("tansig" for hidden layers, "linear" for the last), weights (row-major), biases
//   [bound] (optional) confidence = 0.95, range_dps (the error over the whole grid at once stays
//       within it with that confidence), c = [...] (ascending, at least 2), dps = [...] (one per
//       c: each temperature's own bound, deg/s), how = "..." (optional)
//   [source] (optional, free-form information)
// Every error is an InputError naming the file, the line where known, and the key.
Calibration read_calibration(const std::string& path);
Calibration parse_calibration(std::string_view text, const std::string& name);
fit::BiasModel load_calibration(const std::string& path);

// The file's text; numbers are written so that they read back bit-for-bit.
std::string format_calibration(const fit::BiasModel& model, double scale_mv_per_dps,
                               const CalibrationSource& source = {}, double die_lag_s = 0.0,
                               const std::optional<CalibrationErrorBound>& bound = std::nullopt);
// Writes format_calibration() to path; RuntimeFailure when the file cannot be written.
void save_calibration(const fit::BiasModel& model, const std::string& path,
                      double scale_mv_per_dps = 8.774, const CalibrationSource& source = {},
                      double die_lag_s = 0.0, const std::optional<CalibrationErrorBound>& bound = std::nullopt);

}  // namespace gyrotc::app
