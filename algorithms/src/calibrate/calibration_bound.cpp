#include "gyrotc/algorithms/calibrate/calibration_bound.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <utility>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/calibrate/temperature_bins.hpp"
#include "gyrotc/algorithms/model/random.hpp"
#include "gyrotc/algorithms/stats/block_length.hpp"
#include "gyrotc/algorithms/text/printf_string.hpp"

namespace gyrotc::calibrate {
namespace {

// lo_c, lo_c + step_c, ... and hi_c; a point within a quarter step of hi_c
// gives way to it.
std::vector<double> grid_over(double lo_c, double hi_c, double step_c) {
  std::vector<double> grid;
  for (double t = lo_c; t < hi_c - 0.25 * step_c; t = lo_c + step_c * static_cast<double>(grid.size())) {
    grid.push_back(t);
  }
  grid.push_back(hi_c);
  return grid;
}

// The confidence's order statistic of the values (sorted in place).
double quantile(std::vector<double>& values, double confidence) {
  std::sort(values.begin(), values.end());
  const auto k = static_cast<std::size_t>(std::ceil(confidence * static_cast<double>(values.size())));
  return values[std::clamp<std::size_t>(k, 1, values.size()) - 1];
}

// Runs the replicates (each returns the refitted model, or throws
// std::invalid_argument when the method cannot fit it) and reads the bound
// off their distance from the truth on the grid.
template <typename Replicate>
CalibrationBound bootstrap(const fit::BiasModel& truth, std::vector<double> grid, const BoundOptions& options,
                           Replicate&& replicate) {
  CalibrationBound bound;
  bound.confidence = options.confidence;
  bound.temp_c = std::move(grid);
  std::vector<std::vector<double>> errors(bound.temp_c.size());
  std::vector<double> worst;
  model::Random random(options.seed);
  for (int r = 0; r < options.replicates; ++r) {
    try {
      const fit::BiasModel refit = replicate(random);
      double largest = 0.0;
      for (std::size_t g = 0; g < bound.temp_c.size(); ++g) {
        const double t = bound.temp_c[g];
        const double e = std::fabs(refit.bias_mv(t) - truth.bias_mv(t));
        errors[g].push_back(e);
        largest = std::max(largest, e);
      }
      worst.push_back(largest);
    } catch (const std::invalid_argument&) {
      ++bound.failed;
    }
    if (options.progress) options.progress(r + 1, options.replicates);
  }
  bound.replicates = static_cast<int>(worst.size());
  if (worst.empty()) throw std::invalid_argument("calibration bound: the method could fit none of the replicates");
  for (std::vector<double>& e : errors) bound.bound_mv.push_back(quantile(e, options.confidence));
  bound.range_bound_mv = quantile(worst, options.confidence);
  return bound;
}

// The part of the residual that follows the casing's rate: where the die's
// estimated lag is a little off, or the gyro has a hysteresis, the passes up
// and down sit either side of the curve for the whole of each pass. A bin
// crossed once each way averages it out, and the lag's own draw carries what
// is left of it at the ends; redrawn in blocks as noise it would land at
// random temperatures, one way only, and made the blocks as long as a pass.
void remove_split(std::span<const double> time_s, const std::vector<double>& die_c,
                  const std::vector<std::size_t>& rows, std::vector<double>& residual_mv) {
  constexpr double kRateWindowS = 60.0;  // over the DS18B20's 1/16 C steps
  std::vector<double> rate(rows.size(), 0.0);
  double rr = 0.0;
  double rx = 0.0;
  std::size_t lo = 0;
  std::size_t hi = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const double t = time_s[rows[k]];
    while (time_s[rows[lo]] < t - 0.5 * kRateWindowS) ++lo;
    while (hi + 1 < rows.size() && time_s[rows[hi + 1]] <= t + 0.5 * kRateWindowS) ++hi;
    const double span_s = time_s[rows[hi]] - time_s[rows[lo]];
    if (span_s > 0.0) rate[k] = (die_c[rows[hi]] - die_c[rows[lo]]) / span_s;
    rr += rate[k] * rate[k];
    rx += rate[k] * residual_mv[k];
  }
  if (!(rr > 0.0)) return;
  const double split_mv_per_c_per_s = rx / rr;
  for (std::size_t k = 0; k < rows.size(); ++k) residual_mv[k] -= split_mv_per_c_per_s * rate[k];
}

// The block, in rows, chosen on the residual's means over 30 s: a gyro's
// bias wander is small next to its white noise row by row (a tenth of its
// variance on the study's plants), so its correlation hides under the
// autocorrelation's sampling noise and a slow wander read as none (blocks of
// one row); averaged over 30 s it stands out, and a bin is crossed in 100 s.
std::size_t block_rows(const std::vector<double>& residual_mv, double row_s) {
  constexpr double kGroupS = 30.0;
  const auto group = static_cast<std::size_t>(std::max(1.0, std::round(kGroupS / row_s)));
  std::vector<double> means;
  for (std::size_t i = 0; i + group <= residual_mv.size(); i += group) {
    double sum = 0.0;
    for (std::size_t j = 0; j < group; ++j) sum += residual_mv[i + j];
    means.push_back(sum / static_cast<double>(group));
  }
  if (means.size() < 16) return std::max<std::size_t>(1, residual_mv.size() / 3);
  const double groups = stats::block_bootstrap_length(means);
  return std::clamp<std::size_t>(static_cast<std::size_t>(std::lround(groups * static_cast<double>(group))), 1,
                                 residual_mv.size() / 3);
}

void check_options(const BoundOptions& o) {
  if (!(o.confidence > 0.0 && o.confidence < 1.0)) throw std::invalid_argument("calibration bound: confidence in (0, 1)");
  if (o.replicates < 20) throw std::invalid_argument("calibration bound: at least 20 replicates");
  if (!(o.grid_step_c > 0.0) || !(o.bin_width_c > 0.0)) {
    throw std::invalid_argument("calibration bound: the grid step and the bin width must be positive");
  }
}

}  // namespace

CalibrationBound recording_bound(std::span<const double> time_s, std::span<const double> sensor_c,
                                 std::span<const double> gyro_mv, double die_lag_s, double die_lag_s_std,
                                 const fit::BiasModel& pilot, const fit::MethodOptions& method,
                                 const BoundOptions& options) {
  check_options(options);
  if (time_s.size() != sensor_c.size() || time_s.size() != gyro_mv.size()) {
    throw std::invalid_argument("calibration bound: columns differ in length");
  }
  const std::vector<double> die_c = die_temperature_c(time_s, sensor_c, die_lag_s);
  // The rows the calibration binned, and the noise the model leaves on them.
  std::vector<std::size_t> rows;
  std::vector<double> residual_mv;
  for (std::size_t i = 0; i < die_c.size(); ++i) {
    if (!std::isfinite(die_c[i]) || !std::isfinite(gyro_mv[i])) continue;
    rows.push_back(i);
    residual_mv.push_back(gyro_mv[i] - pilot.bias_mv(die_c[i]));
  }
  if (rows.size() < 16) throw std::invalid_argument("calibration bound: fewer than 16 rows to bootstrap");
  const std::size_t n = rows.size();
  remove_split(time_s, die_c, rows, residual_mv);
  const double row_s = (time_s[rows.back()] - time_s[rows.front()]) / static_cast<double>(n - 1);
  const std::size_t block = block_rows(residual_mv, row_s);
  const TemperatureBins bins = bin_by_temperature(die_c, gyro_mv, options.bin_width_c);
  std::vector<double> grid = grid_over(bins.temp_c.front(), bins.temp_c.back(), options.grid_step_c);

  const bool draw_lag = die_lag_s_std > 0.0 && std::isfinite(die_lag_s_std);
  std::vector<double> binned_c(n);
  std::vector<double> value_mv(n);
  for (std::size_t k = 0; k < n; ++k) binned_c[k] = die_c[rows[k]];
  CalibrationBound bound = bootstrap(pilot, std::move(grid), options, [&](model::Random& random) {
    // The die this replicate's unit had: the sensor through a lag the
    // measurement could not tell from the one it gave.
    const double lag_s = draw_lag ? std::max(0.0, die_lag_s + die_lag_s_std * random.normal()) : die_lag_s;
    const std::vector<double> true_die_c = draw_lag ? die_temperature_c(time_s, sensor_c, lag_s) : die_c;
    std::size_t k = 0;
    while (k < n) {
      const auto start = static_cast<std::size_t>(random.uniform() * static_cast<double>(n - block + 1));
      for (std::size_t j = 0; j < block && k < n; ++j, ++k) {
        value_mv[k] = pilot.bias_mv(true_die_c[rows[k]]) + residual_mv[start + j];
      }
    }
    const TemperatureBins b = bin_by_temperature(binned_c, value_mv, options.bin_width_c);
    return fit::fit_method(b.temp_c, b.gyro_mv, method).model;
  });
  bound.block_s = static_cast<double>(block) * row_s;
  bound.die_lag_s_std = draw_lag ? die_lag_s_std : 0.0;
  bound.how = text::printf_string(
      "bootstrap, %d refits: the residual noise redrawn in blocks of %.0f s of the record", bound.replicates,
      bound.block_s);
  if (draw_lag) bound.how += text::printf_string(", the die's lag drawn from %.1f +/- %.1f s", die_lag_s, die_lag_s_std);
  return bound;
}

CalibrationBound table_bound(std::span<const double> temp_c, std::span<const double> gyro_mv, double dof,
                             const fit::BiasModel& pilot, const fit::MethodOptions& method,
                             const BoundOptions& options) {
  check_options(options);
  if (temp_c.size() != gyro_mv.size()) throw std::invalid_argument("calibration bound: columns differ in length");
  const std::size_t n = temp_c.size();
  if (!(static_cast<double>(n) > dof + 1.0)) {
    throw std::invalid_argument("calibration bound: the fit leaves no residual to bootstrap (as many parameters as points)");
  }
  const double inflate = std::sqrt(static_cast<double>(n) / (static_cast<double>(n) - dof));
  std::vector<double> residual_mv(n);
  for (std::size_t i = 0; i < n; ++i) residual_mv[i] = (gyro_mv[i] - pilot.bias_mv(temp_c[i])) * inflate;
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  std::vector<double> value_mv(n);
  CalibrationBound bound =
      bootstrap(pilot, grid_over(*lo, *hi, options.grid_step_c), options, [&](model::Random& random) {
        for (std::size_t i = 0; i < n; ++i) {
          const auto pick = static_cast<std::size_t>(random.uniform() * static_cast<double>(n));
          value_mv[i] = pilot.bias_mv(temp_c[i]) + residual_mv[std::min(pick, n - 1)];
        }
        return fit::fit_method(temp_c, value_mv, method).model;
      });
  bound.how = text::printf_string("bootstrap, %d refits: the points' residuals redrawn one by one", bound.replicates);
  return bound;
}

fit::MethodOptions pilot_options(const fit::MethodFit& fit, const fit::MethodOptions& method) {
  if (fit.candidates.empty()) return method;
  const auto best = std::min_element(fit.candidates.begin(), fit.candidates.end(),
                                     [](const fit::Candidate& a, const fit::Candidate& b) { return a.score.mse < b.score.mse; });
  fit::MethodOptions pilot = method;
  if (best->name == "spline") {
    pilot.method = fit::Method::spline;
  } else if (best->name == "smooth") {
    pilot.method = fit::Method::smoothing;
  } else if (best->name.rfind("poly ", 0) == 0) {
    pilot.method = fit::Method::polynomial;
    pilot.orders = {std::stoi(best->name.substr(5))};
  }
  return pilot;
}

fit::MethodFit fit_pilot(std::span<const double> temp_c, std::span<const double> gyro_mv, const fit::MethodFit& fit,
                         const fit::MethodOptions& method) {
  constexpr double kUndersmoothing = 2.0;  // chosen on the study's seeds 1-20 (docs/SELFCAL.md)
  if (fit.candidates.empty() && fit.method != fit::Method::smoothing) return fit;
  fit::MethodOptions options = pilot_options(fit, method);
  fit::MethodFit pilot = fit.candidates.empty() ? fit : fit::fit_method(temp_c, gyro_mv, options);
  if (pilot.method != fit::Method::smoothing) return pilot;
  options.method = fit::Method::smoothing;
  options.smoothing.dof = std::min(static_cast<double>(temp_c.size()) - 2.0, kUndersmoothing * pilot.dof);
  return fit::fit_method(temp_c, gyro_mv, options);
}

double bound_at_mv(const CalibrationBound& bound, double temp_c) {
  const std::vector<double>& t = bound.temp_c;
  if (t.empty()) return NAN;
  if (temp_c <= t.front()) return bound.bound_mv.front();
  if (temp_c >= t.back()) return bound.bound_mv.back();
  const auto it = std::upper_bound(t.begin(), t.end(), temp_c);
  const std::size_t i = static_cast<std::size_t>(it - t.begin());
  const double w = (temp_c - t[i - 1]) / (t[i] - t[i - 1]);
  return bound.bound_mv[i - 1] + w * (bound.bound_mv[i] - bound.bound_mv[i - 1]);
}

}  // namespace gyrotc::calibrate
