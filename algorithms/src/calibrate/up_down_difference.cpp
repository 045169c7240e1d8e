#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"

#include <cmath>
#include <cstdint>
#include <map>

#include "gyrotc/algorithms/fit/record_screen.hpp"

namespace gyrotc::calibrate {

UpDownDifference up_down_difference(std::span<const double> time_s, std::span<const double> sensor_c,
                                    std::span<const double> gyro_mv, const UpDownOptions& options) {
  const std::vector<double> rate = fit::rates_c_per_min(time_s, sensor_c, options.rate_window_s);
  struct Sums {
    double up_mv = 0.0, down_mv = 0.0;
    std::size_t up = 0, down = 0;
  };
  std::map<std::int64_t, Sums> bins;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (!std::isfinite(sensor_c[i]) || !std::isfinite(gyro_mv[i])) continue;
    Sums& b = bins[static_cast<std::int64_t>(std::floor(sensor_c[i] / options.bin_width_c))];
    if (rate[i] > options.min_rate_c_per_min) {
      b.up_mv += gyro_mv[i];
      ++b.up;
    } else if (rate[i] < -options.min_rate_c_per_min) {
      b.down_mv += gyro_mv[i];
      ++b.down;
    }
  }
  UpDownDifference d;
  double sum_abs = 0.0;
  for (const auto& [index, b] : bins) {
    if (b.up < options.min_rows_per_pass || b.down < options.min_rows_per_pass) continue;
    UpDownBin bin{(static_cast<double>(index) + 0.5) * options.bin_width_c, b.up_mv / static_cast<double>(b.up),
                  b.down_mv / static_cast<double>(b.down), b.up, b.down};
    const double diff = std::fabs(bin.up_mv - bin.down_mv);
    if (diff > d.max_abs_mv) {
      d.max_abs_mv = diff;
      d.max_at_c = bin.temp_c;
    }
    sum_abs += diff;
    d.bins.push_back(bin);
  }
  if (!d.bins.empty()) d.mean_abs_mv = sum_abs / static_cast<double>(d.bins.size());
  return d;
}

}  // namespace gyrotc::calibrate
