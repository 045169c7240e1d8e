#include "gyrotc/algorithms/model/gyro_bias_curve.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>

namespace gyrotc::model {
namespace {

// Seed Table 1 (drive mode), -40..60 C in 10 C steps.
constexpr double kTable1FirstC = -40.0;
constexpr double kTable1StepC = 10.0;
constexpr std::array<double, 11> kDriveHz = {2475.35, 2474.86, 2474.35, 2473.50, 2473.02, 2472.30,
                                             2471.60, 2470.20, 2469.40, 2468.90, 2468.30};
constexpr std::array<double, 11> kDriveQ = {19041, 17678, 16495, 15459, 13739, 10749,
                                            9886,  8822,  8232,  7482,  7052};

double interpolate(const std::array<double, 11>& y, double temp_c) {
  if (!std::isfinite(temp_c)) return y[0];
  const double x = std::clamp((temp_c - kTable1FirstC) / kTable1StepC, 0.0, 10.0);
  const auto i = std::min<std::size_t>(static_cast<std::size_t>(x), 9);
  const double f = x - static_cast<double>(i);
  return y[i] + f * (y[i + 1] - y[i]);
}

std::vector<double> table2_temps_c() {
  std::vector<double> t;
  for (std::size_t i = 0; i < kTable2GyroMv.size(); ++i) t.push_back(kTable2FirstC + kTable2StepC * static_cast<double>(i));
  return t;
}

// Natural spline: M[0] = M[n-1] = 0 and, for 0 < i < n-1,
// h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (d[i] - d[i-1]),
// d the slopes between points; the Thomas algorithm solves it in place.
std::vector<double> natural_spline_second_derivatives(const std::vector<double>& t, const std::vector<double>& y) {
  const std::size_t n = t.size();
  std::vector<double> m(n, 0.0);      // the forward sweep's right-hand side, then M
  std::vector<double> upper(n, 0.0);  // the forward sweep's super-diagonal
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double h0 = t[i] - t[i - 1];
    const double h1 = t[i + 1] - t[i];
    const double rhs = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
    const double denom = 2.0 * (h0 + h1) - h0 * upper[i - 1];
    upper[i] = h1 / denom;
    m[i] = (rhs - h0 * m[i - 1]) / denom;
  }
  for (std::size_t i = n - 1; i-- > 1;) m[i] -= upper[i] * m[i + 1];
  return m;
}

}  // namespace

ZeroBiasCurve::ZeroBiasCurve() : ZeroBiasCurve(table2_temps_c(), {kTable2GyroMv.begin(), kTable2GyroMv.end()}) {}

ZeroBiasCurve::ZeroBiasCurve(std::vector<double> temp_c, std::vector<double> gyro_mv)
    : temp_c_(std::move(temp_c)), gyro_mv_(std::move(gyro_mv)) {
  const std::size_t n = temp_c_.size();
  if (gyro_mv_.size() != n) {
    throw std::invalid_argument("zero-bias curve: " + std::to_string(n) + " temperatures but " +
                                std::to_string(gyro_mv_.size()) + " outputs");
  }
  if (n < 2) throw std::invalid_argument("zero-bias curve: needs at least 2 points");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(temp_c_[i]) || !std::isfinite(gyro_mv_[i])) {
      throw std::invalid_argument("zero-bias curve: point " + std::to_string(i + 1) + " is not a finite number");
    }
    if (i > 0 && !(temp_c_[i] > temp_c_[i - 1])) {
      throw std::invalid_argument("zero-bias curve: temperature " + std::to_string(i + 1) +
                                  " does not rise above the one before");
    }
  }
  second_derivatives_ = natural_spline_second_derivatives(temp_c_, gyro_mv_);
}

// The derivative of segment i at offset_c above its first point.
double ZeroBiasCurve::slope(std::size_t i, double offset_c) const noexcept {
  const double h = temp_c_[i + 1] - temp_c_[i];
  const double u = h - offset_c;
  const double m0 = second_derivatives_[i];
  const double m1 = second_derivatives_[i + 1];
  return -m0 * u * u / (2.0 * h) + m1 * offset_c * offset_c / (2.0 * h) + (gyro_mv_[i + 1] - gyro_mv_[i]) / h -
         (m1 - m0) * h / 6.0;
}

double ZeroBiasCurve::bias_mv(double temp_c) const noexcept {
  const std::size_t n = temp_c_.size();
  if (!std::isfinite(temp_c)) return gyro_mv_[0];
  if (temp_c <= temp_c_[0]) return gyro_mv_[0] + slope(0, 0.0) * (temp_c - temp_c_[0]);
  if (temp_c >= temp_c_[n - 1]) {
    return gyro_mv_[n - 1] + slope(n - 2, temp_c_[n - 1] - temp_c_[n - 2]) * (temp_c - temp_c_[n - 1]);
  }
  const auto above = std::upper_bound(temp_c_.begin(), temp_c_.end(), temp_c);
  const auto i = static_cast<std::size_t>(above - temp_c_.begin()) - 1;
  const double h = temp_c_[i + 1] - temp_c_[i];
  const double t = temp_c - temp_c_[i];
  const double u = h - t;
  const double m0 = second_derivatives_[i];
  const double m1 = second_derivatives_[i + 1];
  return m0 * u * u * u / (6.0 * h) + m1 * t * t * t / (6.0 * h) + (gyro_mv_[i] / h - m0 * h / 6.0) * u +
         (gyro_mv_[i + 1] / h - m1 * h / 6.0) * t;
}

double table2_bias_mv(double temp_c) noexcept {
  static const ZeroBiasCurve table2;
  return table2.bias_mv(temp_c);
}

double table1_drive_frequency_hz(double temp_c) noexcept { return interpolate(kDriveHz, temp_c); }
double table1_drive_q(double temp_c) noexcept { return interpolate(kDriveQ, temp_c); }

}  // namespace gyrotc::model
