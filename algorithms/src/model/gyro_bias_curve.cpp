#include "gyrotc/algorithms/model/gyro_bias_curve.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace gyrotc::model {
namespace {

constexpr std::size_t kN = kTable2GyroMv.size();

// Second derivatives of the natural cubic spline on the uniform Table 2 grid:
// M[0] = M[n-1] = 0, M[i-1] + 4 M[i] + M[i+1] = 6 (y[i-1] - 2 y[i] + y[i+1]) / h^2,
// solved by the Thomas algorithm at compile time.
constexpr std::array<double, kN> spline_second_derivatives() {
  const double h = kTable2StepC;
  const auto& y = kTable2GyroMv;
  std::array<double, kN> m{};
  std::array<double, kN> c{};  // modified super-diagonal
  std::array<double, kN> d{};  // modified right-hand side
  for (std::size_t i = 1; i + 1 < kN; ++i) {
    const double rhs = 6.0 * (y[i - 1] - 2.0 * y[i] + y[i + 1]) / (h * h);
    const double denom = 4.0 - (i > 1 ? c[i - 1] : 0.0);
    c[i] = 1.0 / denom;
    d[i] = (rhs - (i > 1 ? d[i - 1] : 0.0)) / denom;
  }
  for (std::size_t i = kN - 2; i >= 1; --i) {
    m[i] = d[i] - c[i] * m[i + 1];
  }
  return m;
}

constexpr std::array<double, kN> kM = spline_second_derivatives();

double spline_slope(std::size_t i, double t) {
  // Derivative of segment i at local coordinate t in [0, h].
  const double h = kTable2StepC;
  const auto& y = kTable2GyroMv;
  const double u = h - t;
  return -kM[i] * u * u / (2.0 * h) + kM[i + 1] * t * t / (2.0 * h) + (y[i + 1] - y[i]) / h -
         (kM[i + 1] - kM[i]) * h / 6.0;
}

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

}  // namespace

double table2_bias_mv(double temp_c) noexcept {
  const double h = kTable2StepC;
  const auto& y = kTable2GyroMv;
  const double last_c = kTable2FirstC + h * static_cast<double>(kN - 1);
  if (!std::isfinite(temp_c)) return y[0];
  if (temp_c <= kTable2FirstC) return y[0] + spline_slope(0, 0.0) * (temp_c - kTable2FirstC);
  if (temp_c >= last_c) return y[kN - 1] + spline_slope(kN - 2, h) * (temp_c - last_c);
  const double x = (temp_c - kTable2FirstC) / h;
  const auto i = std::min<std::size_t>(static_cast<std::size_t>(x), kN - 2);
  const double t = temp_c - (kTable2FirstC + h * static_cast<double>(i));
  const double u = h - t;
  return kM[i] * u * u * u / (6.0 * h) + kM[i + 1] * t * t * t / (6.0 * h) +
         (y[i] / h - kM[i] * h / 6.0) * u + (y[i + 1] / h - kM[i + 1] * h / 6.0) * t;
}

double table1_drive_frequency_hz(double temp_c) noexcept { return interpolate(kDriveHz, temp_c); }
double table1_drive_q(double temp_c) noexcept { return interpolate(kDriveQ, temp_c); }

}  // namespace gyrotc::model
