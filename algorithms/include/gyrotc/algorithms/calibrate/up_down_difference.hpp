#pragma once
// How the gyro's output differs between the self-calibration's upward and
// downward passes at the same casing temperature (issue 30): the die's lag
// behind the casing sensor shifts the two passes by opposite amounts, and a
// bias with hysteresis adds its own split. The calibration fits their mean;
// the split is what a unit sees when it warms or cools through that
// temperature at the sweep's rate.
#include <cstddef>
#include <span>
#include <vector>

namespace gyrotc::calibrate {

struct UpDownBin {
  double temp_c = 0.0;  // the bin's centre
  double up_mv = 0.0;   // mean gyro output of the rows moving up
  double down_mv = 0.0;
  std::size_t up_rows = 0;
  std::size_t down_rows = 0;
};

struct UpDownDifference {
  std::vector<UpDownBin> bins;  // those crossed both ways, coolest first
  double max_abs_mv = 0.0;      // largest |up - down|
  double max_at_c = 0.0;        // where
  double mean_abs_mv = 0.0;     // mean |up - down| over the bins
};

struct UpDownOptions {
  double bin_width_c = 1.0;             // as `fit` bins a record
  double rate_window_s = 60.0;          // the casing's rate, as fit's record screen reads it
  double min_rate_c_per_min = 0.1;      // slower rows (the dwells at the ends) count for neither pass
  std::size_t min_rows_per_pass = 10;   // a bin needs this many rows each way
};

UpDownDifference up_down_difference(std::span<const double> time_s, std::span<const double> sensor_c,
                                    std::span<const double> gyro_mv, const UpDownOptions& options = {});

}  // namespace gyrotc::calibrate
