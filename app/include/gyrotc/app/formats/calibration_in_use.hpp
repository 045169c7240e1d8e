#pragma once

#include <optional>
#include <string>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"

namespace gyrotc::app {

// The calibration a configuration's [calibration] file names, loaded, with
// what a user needs to tell which one a unit runs: `gyrotc probe` and the
// daemon's start-up and reload log lines print describe().
struct CalibrationInUse {
  std::string file;  // as configured (absolute); "" = the seed's built-in reference model
  fit::BiasModel model = fit::BiasModel::paper_reference();
  double scale_mv_per_dps = 8.774;
  double die_lag_s = 0.0;  // the file's die_lag_s: compensated at the die's estimated temperature
  std::string sha256;  // of the file's bytes ("" for the built-in model)
  std::optional<CalibrationErrorBound> bound;  // the file's [bound]: its own error bound
};

// Loads `file` ("" = the built-in model). A missing or invalid file is an
// InputError naming the file (and the line and key where it is bad): never a
// silent fall-back to the seed's model.
CalibrationInUse load_calibration_in_use(const std::string& file);

// "/etc/gyrotc/calibration.toml: piecewise, -40..80 C, sha256 1f2e..." (the
// first 16 hex digits; "of the die, 42.2 s behind the sensor" after the range
// when die_lag_s > 0; "error <= 0.0091 deg/s (95 %) over 8.0..67.0 C" when the
// file has a [bound]), or "the seed's built-in reference model (...)".
std::string describe(const CalibrationInUse& calibration);

}  // namespace gyrotc::app
