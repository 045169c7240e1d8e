#include "gyrotc/algorithms/calibrate/die_lag_from_record.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/fit/record_screen.hpp"
#include "gyrotc/algorithms/tune/residual_noise.hpp"

namespace gyrotc::calibrate {
namespace {

// A run of consecutive usable rows, averaged into one row of the fit.
struct Chunk {
  std::size_t from = 0;  // rows [from, to)
  std::size_t to = 0;
  double direction = 0.0;  // the rows' mean direction, -1..1 (chunks_of)
  double gyro_mv = 0.0;    // the rows' mean
};

class LagFit {
 public:
  LagFit(std::span<const double> time_s, std::span<const double> sensor_c, std::vector<Chunk> chunks,
         double low_knot_c, std::size_t knots, double spacing_c)
      : time_s_(time_s), sensor_c_(sensor_c), chunks_(std::move(chunks)), low_c_(low_knot_c), knots_(knots),
        spacing_c_(spacing_c) {
    y_.resize(static_cast<Eigen::Index>(chunks_.size()));
    for (std::size_t c = 0; c < chunks_.size(); ++c) y_(static_cast<Eigen::Index>(c)) = chunks_[c].gyro_mv;
  }

  Eigen::Index columns() const { return static_cast<Eigen::Index>(knots_) + 1; }  // the curve's knots, the split

  // The design at a lag: each chunk's rows' hat functions of the die's
  // temperature, averaged, and half its direction.
  Eigen::MatrixXd design(double lag_s) const {
    const std::vector<double> die = die_temperature_c(time_s_, sensor_c_, lag_s);
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(chunks_.size()), columns());
    for (std::size_t c = 0; c < chunks_.size(); ++c) {
      const Chunk& chunk = chunks_[c];
      const auto row = static_cast<Eigen::Index>(c);
      const double weight = 1.0 / static_cast<double>(chunk.to - chunk.from);
      for (std::size_t i = chunk.from; i < chunk.to; ++i) {
        const double u = std::clamp((die[i] - low_c_) / spacing_c_, 0.0, static_cast<double>(knots_ - 1));
        const auto k = std::min(static_cast<std::size_t>(u), knots_ - 2);
        const double w = u - static_cast<double>(k);
        x(row, static_cast<Eigen::Index>(k)) += weight * (1.0 - w);
        x(row, static_cast<Eigen::Index>(k) + 1) += weight * w;
      }
      x(row, columns() - 1) = 0.5 * chunk.direction;
    }
    return x;
  }

  struct Solution {
    Eigen::VectorXd beta;
    double rss = 0.0;
  };

  Solution solve(const Eigen::MatrixXd& x) const {
    Eigen::MatrixXd normal = x.transpose() * x;
    // A knot no die temperature came near has no data: a whisper of ridge
    // keeps it at zero instead of the solve failing.
    normal.diagonal().array() += 1e-12 * std::max(1.0, normal.diagonal().mean());
    Solution s;
    s.beta = normal.ldlt().solve(x.transpose() * y_);
    s.rss = (y_ - x * s.beta).squaredNorm();
    return s;
  }

  double rss(double lag_s) const { return solve(design(lag_s)).rss; }
  const Eigen::VectorXd& y() const { return y_; }

 private:
  std::span<const double> time_s_;
  std::span<const double> sensor_c_;
  std::vector<Chunk> chunks_;
  double low_c_;
  std::size_t knots_;
  double spacing_c_;
  Eigen::VectorXd y_;
};

// Runs of up to rows_per_chunk consecutive usable rows. The direction is
// the casing's rate over the sweep's (the median rate of the rows that
// move), within -1..1: it steps from 0 to 1 where a ramp begins, smoothed
// by the rate's window but centred on the step (a threshold on the rate
// would switch half a window early at a ramp's start and late at its end).
std::vector<Chunk> chunks_of(std::span<const double> sensor_c, std::span<const double> gyro_mv,
                             const std::vector<double>& rate, const RecordLagOptions& options) {
  std::vector<double> moving;
  for (double r : rate) {
    if (std::isfinite(r) && std::fabs(r) > options.min_rate_c_per_min) moving.push_back(std::fabs(r));
  }
  if (moving.empty()) return {};
  std::nth_element(moving.begin(), moving.begin() + static_cast<std::ptrdiff_t>(moving.size() / 2), moving.end());
  const double sweep_rate = moving[moving.size() / 2];
  std::vector<Chunk> chunks;
  for (std::size_t i = 0; i < sensor_c.size(); ++i) {
    if (!std::isfinite(sensor_c[i]) || !std::isfinite(gyro_mv[i]) || !std::isfinite(rate[i])) continue;
    if (chunks.empty() || chunks.back().to != i ||
        chunks.back().to - chunks.back().from >= std::max<std::size_t>(1, options.rows_per_chunk)) {
      chunks.push_back({i, i, 0.0, 0.0});
    }
    Chunk& c = chunks.back();
    c.direction += std::clamp(rate[i] / sweep_rate, -1.0, 1.0);
    c.gyro_mv += gyro_mv[i];
    c.to = i + 1;
  }
  for (Chunk& c : chunks) {
    c.direction /= static_cast<double>(c.to - c.from);
    c.gyro_mv /= static_cast<double>(c.to - c.from);
  }
  return chunks;
}

}  // namespace

RecordLag die_lag_from_record(std::span<const double> time_s, std::span<const double> sensor_c,
                              std::span<const double> gyro_mv, const RecordLagOptions& options) {
  if (time_s.size() != sensor_c.size() || time_s.size() != gyro_mv.size()) {
    throw std::invalid_argument("die_lag_from_record: time, sensor and gyro differ in length");
  }
  for (std::size_t i = 1; i < time_s.size(); ++i) {
    if (time_s[i] < time_s[i - 1]) throw std::invalid_argument("die_lag_from_record: time decreases");
  }
  RecordLag out;
  const std::vector<double> rate = fit::rates_c_per_min(time_s, sensor_c, options.rate_window_s);
  std::vector<Chunk> chunks = chunks_of(sensor_c, gyro_mv, rate, options);
  double low = INFINITY, high = -INFINITY;
  for (double c : sensor_c) {
    if (!std::isfinite(c)) continue;
    low = std::min(low, c);
    high = std::max(high, c);
  }
  const double spacing = options.knot_spacing_c;
  if (!(high - low >= 2.0 * spacing)) {
    out.why_not = "the casing moved too little to show the die's lag";
    return out;
  }
  const double low_knot = std::floor(low / spacing) * spacing;
  const auto knots = static_cast<std::size_t>(std::ceil((high - low_knot) / spacing)) + 1;
  if (chunks.size() < 4 * (knots + 2)) {
    out.why_not = "too few rows to show the die's lag";
    return out;
  }
  const LagFit fit(time_s, sensor_c, std::move(chunks), low_knot, knots, spacing);

  // The grid, then a golden-section search about its best point.
  double best_lag = 0.0;
  double best_rss = INFINITY;
  for (double lag = 0.0; lag <= options.max_lag_s + 1e-9; lag += options.lag_step_s) {
    const double r = fit.rss(lag);
    if (r < best_rss) {
      best_rss = r;
      best_lag = lag;
    }
  }
  if (best_lag >= options.max_lag_s - 1e-9) {
    out.why_not = "the record fits better the longer the lag, up to the search's end (" +
                  std::to_string(static_cast<int>(options.max_lag_s)) + " s): not a die's lag";
    return out;
  }
  double a = std::max(0.0, best_lag - options.lag_step_s);
  double b = best_lag + options.lag_step_s;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = fit.rss(c), fd = fit.rss(d);
  while (b - a > 0.05) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = fit.rss(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = fit.rss(d);
    }
  }
  const double lag = 0.5 * (a + b);

  // Linearised at the lag: the curve's and the split's columns, and the
  // model's change with the lag (the fitted curve at the die a lag of
  // +-h away), for the standard error.
  const Eigen::MatrixXd x = fit.design(lag);
  const LagFit::Solution s = fit.solve(x);
  const double h = std::max(0.5, 0.01 * lag);
  const Eigen::VectorXd lag_column =
      (fit.design(lag + h) * s.beta - fit.design(std::max(0.0, lag - h)) * s.beta) / (lag + h - std::max(0.0, lag - h));
  Eigen::MatrixXd jacobian(x.rows(), x.cols() + 1);
  jacobian << x, lag_column;
  Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
  normal.diagonal().array() += 1e-12 * std::max(1.0, normal.diagonal().mean());
  const Eigen::LDLT<Eigen::MatrixXd> solver(normal);
  const Eigen::MatrixXd inverse = solver.solve(Eigen::MatrixXd::Identity(normal.rows(), normal.cols()));
  const Eigen::VectorXd residual = fit.y() - x * s.beta;
  const tune::ResidualNoise noise = tune::fit_residual_noise(jacobian, residual);
  const Eigen::MatrixXd covariance = tune::noise_covariance(jacobian, inverse, noise);
  const Eigen::Index last = jacobian.cols() - 1;
  const double se = std::sqrt(std::max(0.0, covariance(last, last)));
  out.die_lag_s = lag;
  out.die_lag_s_std = se;
  out.split_mv = s.beta(x.cols() - 1);
  if (!std::isfinite(se) || !(se > 0.0)) {
    out.why_not = "the fit of the record is singular";
    return out;
  }
  if (lag < options.min_lag_s || lag < options.min_z * se) {
    char what[96];
    std::snprintf(what, sizeof what, "no lag beyond the noise: %.1f +/- %.1f s (under %.0f s or %.0f standard errors)",
                  lag, se, options.min_lag_s, options.min_z);
    out.why_not = what;
    return out;
  }
  out.found = true;
  return out;
}

}  // namespace gyrotc::calibrate
