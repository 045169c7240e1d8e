#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>

#include <Eigen/Dense>

#include "gyrotc/algorithms/fit/record_screen.hpp"
#include "gyrotc/algorithms/tune/residual_noise.hpp"

namespace gyrotc::calibrate {
namespace {

std::int64_t bin_index(double temp_c, const UpDownOptions& options) {
  return static_cast<std::int64_t>(std::floor(temp_c / options.bin_width_c));
}

// +1 moving up, -1 down, 0 slower than min_rate_c_per_min (a dwell).
int direction_of(double rate_c_per_min, const UpDownOptions& options) {
  if (rate_c_per_min > options.min_rate_c_per_min) return 1;
  return rate_c_per_min < -options.min_rate_c_per_min ? -1 : 0;
}

// The curve's slope at each bin, from the bins' means: a quadratic in
// temperature through the bins within half_width_c (at the ends of the range
// the window is one-sided, and the quadratic keeps the slope unbiased on a
// curve). NaN where fewer than 4 bins are that close.
std::vector<double> slopes_mv_per_c(const std::vector<UpDownBin>& bins, double half_width_c) {
  std::vector<double> slopes;
  for (const UpDownBin& b : bins) {
    Eigen::MatrixXd x(static_cast<Eigen::Index>(bins.size()), 3);
    Eigen::VectorXd y(static_cast<Eigen::Index>(bins.size()));
    Eigen::Index m = 0;
    for (const UpDownBin& o : bins) {
      const double dt = o.temp_c - b.temp_c;
      if (std::fabs(dt) > half_width_c + 1e-9) continue;
      x.row(m) << 1.0, dt, dt * dt;
      y(m) = 0.5 * (o.up_mv + o.down_mv);
      ++m;
    }
    slopes.push_back(m < 4 ? std::numeric_limits<double>::quiet_NaN()
                           : x.topRows(m).colPivHouseholderQr().solve(y.head(m))(1));
  }
  return slopes;
}

// The rows the separation reads: one of a bin's two passes, settled.
struct PassRow {
  std::size_t row;
  std::size_t bin;  // index into the bins with a slope
  double sign;      // +1 up, -1 down
};

LagAndHysteresis separate(std::span<const double> sensor_c, std::span<const double> gyro_mv,
                          const std::vector<double>& rate, const std::vector<bool>& use,
                          const std::vector<UpDownBin>& bins, const UpDownOptions& options) {
  LagAndHysteresis out;
  // up - down = lag * column + hysteresis, column = -(r_up + r_down) B'(T), in mV/s.
  const std::vector<double> slopes = slopes_mv_per_c(bins, options.slope_half_width_c);
  std::map<std::int64_t, std::size_t> column_of_bin;
  std::vector<double> column;
  std::vector<const UpDownBin*> bins_with_slope;
  for (std::size_t k = 0; k < bins.size(); ++k) {
    const UpDownBin& b = bins[k];
    if (!std::isfinite(slopes[k])) continue;
    bins_with_slope.push_back(&b);
    column_of_bin[bin_index(b.temp_c, options)] = column.size();
    column.push_back(-(b.up_rate_c_per_min + b.down_rate_c_per_min) / 60.0 * slopes[k]);
  }
  const std::size_t m = column.size();
  if (m < options.min_bins_to_separate) {
    out.why_not = "too few temperatures crossed both ways (" + std::to_string(m) + ")";
    return out;
  }
  double mean = 0.0, square = 0.0;
  for (double c : column) {
    mean += c;
    square += c * c;
  }
  mean /= static_cast<double>(m);
  const double rms = std::sqrt(square / static_cast<double>(m));
  const double spread = std::sqrt(std::max(0.0, square / static_cast<double>(m) - mean * mean));
  if (!(rms > 0.0) || spread < options.min_slope_spread * rms) {
    out.why_not = "the curve's slope hardly changes over the range swept, so the die's lag and a hysteresis split "
                  "the passes alike (where the casing starts, stops and turns the record may still show the lag)";
    return out;
  }
  // Row by row, in time: y = level of the bin + sign (lag column + hysteresis) / 2.
  // The levels take the curve; what is left is the gyro's own noise, whose
  // white and wandering parts are fitted to that residual with the fit's
  // projection accounted for (tune/residual_noise.hpp), as tune does: a
  // wander slower than a bin's crossing shows only partly in the residual
  // (the levels take the rest), but it moves the passes' split, and a
  // standard error read off the bins' scatter alone came out 30 % small on
  // a 100 s wander.
  std::vector<PassRow> rows;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (!use[i] || !std::isfinite(sensor_c[i]) || !std::isfinite(gyro_mv[i])) continue;
    const auto it = column_of_bin.find(bin_index(sensor_c[i], options));
    const int direction = direction_of(rate[i], options);
    if (it != column_of_bin.end() && direction != 0) rows.push_back({i, it->second, static_cast<double>(direction)});
  }
  if (rows.empty()) {
    out.why_not = "no row of the passes moved one way long enough to read the die's lag";
    return out;
  }
  // Runs of up to kRowsPerChunk consecutive rows of one bin and pass are
  // averaged into one (the noise fit below costs columns^2 x rows per lag).
  constexpr std::size_t kRowsPerChunk = 5;
  std::vector<std::size_t> chunk_start{0};
  for (std::size_t t = 1; t < rows.size(); ++t) {
    const PassRow& a = rows[t - 1];
    const PassRow& b = rows[t];
    if (b.row != a.row + 1 || b.bin != a.bin || b.sign != a.sign || t - chunk_start.back() >= kRowsPerChunk) {
      chunk_start.push_back(t);
    }
  }
  const auto n = static_cast<Eigen::Index>(chunk_start.size());
  const auto levels = static_cast<Eigen::Index>(m);
  // Each bin's level and the curve's slope across it (a bowl moves by a
  // millivolt within a 1 C bin: that is curve, not noise), then the lag and
  // the hysteresis.
  const Eigen::Index lag_column = 2 * levels;
  Eigen::MatrixXd design = Eigen::MatrixXd::Zero(n, lag_column + 2);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
  for (Eigen::Index c = 0; c < n; ++c) {
    const std::size_t from = chunk_start[static_cast<std::size_t>(c)];
    const std::size_t to = c + 1 < n ? chunk_start[static_cast<std::size_t>(c + 1)] : rows.size();
    const PassRow& first = rows[from];
    const auto bin = static_cast<Eigen::Index>(first.bin);
    const auto count = static_cast<double>(to - from);
    double offset_c = 0.0;
    for (std::size_t t = from; t < to; ++t) {
      offset_c += sensor_c[rows[t].row] - bins_with_slope[first.bin]->temp_c;
      y(c) += gyro_mv[rows[t].row];
    }
    y(c) /= count;
    design(c, bin) = 1.0;
    design(c, levels + bin) = offset_c / count;
    design(c, lag_column) = 0.5 * first.sign * column[first.bin];
    design(c, lag_column + 1) = 0.5 * first.sign;
  }
  const Eigen::MatrixXd normal = design.transpose() * design;
  const Eigen::LDLT<Eigen::MatrixXd> solver(normal);
  const Eigen::VectorXd beta = solver.solve(design.transpose() * y);
  const Eigen::VectorXd residual = y - design * beta;
  const Eigen::MatrixXd inverse = solver.solve(Eigen::MatrixXd::Identity(lag_column + 2, lag_column + 2));
  const tune::ResidualNoise noise = tune::fit_residual_noise(design, residual);
  const Eigen::MatrixXd covariance = tune::noise_covariance(design, inverse, noise);
  if (!beta.allFinite() || !covariance.allFinite()) {
    out.why_not = "the fit of the passes is singular (a bin whose temperature did not change across it?)";
    return out;
  }
  out.separated = true;
  out.die_lag_s = beta(lag_column);
  out.die_lag_s_std = std::sqrt(std::max(0.0, covariance(lag_column, lag_column)));
  out.split_mv = beta(lag_column + 1);
  out.split_mv_std = std::sqrt(std::max(0.0, covariance(lag_column + 1, lag_column + 1)));
  return out;
}

// The bins crossed both ways by the rows `use` admits (all when empty).
std::vector<UpDownBin> bin_passes(std::span<const double> sensor_c, std::span<const double> gyro_mv,
                                  const std::vector<double>& rate, const std::vector<bool>& use,
                                  const UpDownOptions& options) {
  struct Sums {
    double up_mv = 0.0, down_mv = 0.0;
    double up_rate = 0.0, down_rate = 0.0;
    std::size_t up = 0, down = 0;
  };
  std::map<std::int64_t, Sums> sums;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (!std::isfinite(sensor_c[i]) || !std::isfinite(gyro_mv[i]) || (!use.empty() && !use[i])) continue;
    Sums& b = sums[bin_index(sensor_c[i], options)];
    const int direction = direction_of(rate[i], options);
    if (direction > 0) {
      b.up_mv += gyro_mv[i];
      b.up_rate += rate[i];
      ++b.up;
    } else if (direction < 0) {
      b.down_mv += gyro_mv[i];
      b.down_rate -= rate[i];
      ++b.down;
    }
  }
  std::vector<UpDownBin> bins;
  for (const auto& [index, b] : sums) {
    if (b.up < options.min_rows_per_pass || b.down < options.min_rows_per_pass) continue;
    const auto up = static_cast<double>(b.up);
    const auto down = static_cast<double>(b.down);
    bins.push_back({(static_cast<double>(index) + 0.5) * options.bin_width_c, b.up_mv / up, b.down_mv / down, b.up,
                    b.down, b.up_rate / up, b.down_rate / down});
  }
  return bins;
}

// The rows that have moved one way for at least settle_s: a die that lags
// the casing by tau reaches its steady lag only ~3 tau into a pass, so the
// rows near a turn or the start would read a smaller lag than the rest.
std::vector<bool> settled_rows(std::span<const double> time_s, const std::vector<double>& rate,
                               const UpDownOptions& options) {
  std::vector<bool> use(rate.size(), false);
  double since_s = 0.0;
  int direction = 0;
  for (std::size_t i = 0; i < rate.size(); ++i) {
    const int d = direction_of(rate[i], options);
    if (d == 0 || d != direction) {
      direction = d;
      since_s = time_s[i];
    }
    use[i] = d != 0 && time_s[i] - since_s >= options.pass_settle_s;
  }
  return use;
}

}  // namespace

UpDownDifference up_down_difference(std::span<const double> time_s, std::span<const double> sensor_c,
                                    std::span<const double> gyro_mv, const UpDownOptions& options) {
  const std::vector<double> rate = fit::rates_c_per_min(time_s, sensor_c, options.rate_window_s);
  UpDownDifference d;
  d.bins = bin_passes(sensor_c, gyro_mv, rate, {}, options);
  double sum_abs = 0.0;
  for (UpDownBin& bin : d.bins) {
    const double diff = std::fabs(bin.up_mv - bin.down_mv);
    if (diff > d.max_abs_mv) {
      d.max_abs_mv = diff;
      d.max_at_c = bin.temp_c;
    }
    sum_abs += diff;
  }
  if (!d.bins.empty()) d.mean_abs_mv = sum_abs / static_cast<double>(d.bins.size());
  const std::vector<bool> use = settled_rows(time_s, rate, options);
  const std::vector<UpDownBin> settled = bin_passes(sensor_c, gyro_mv, rate, use, options);
  d.separation = separate(sensor_c, gyro_mv, rate, use, settled, options);
  return d;
}

}  // namespace gyrotc::calibrate
