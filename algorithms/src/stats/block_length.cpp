#include "gyrotc/algorithms/stats/block_length.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace gyrotc::stats {
namespace {

// Autocovariances R(0..max_lag) of the demeaned series, divided by n.
std::vector<double> autocovariance(std::span<const double> x, std::size_t max_lag) {
  const std::size_t n = x.size();
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  std::vector<double> r(max_lag + 1, 0.0);
  for (std::size_t k = 0; k <= max_lag; ++k) {
    double s = 0.0;
    for (std::size_t i = k; i < n; ++i) s += (x[i] - mean) * (x[i - k] - mean);
    r[k] = s / static_cast<double>(n);
  }
  return r;
}

// The flat-top window of Politis & Romano: 1 to half its width, then linear to 0.
double flat_top(double t) {
  const double a = std::fabs(t);
  if (a <= 0.5) return 1.0;
  if (a <= 1.0) return 2.0 * (1.0 - a);
  return 0.0;
}

}  // namespace

double block_bootstrap_length(std::span<const double> series) {
  const std::size_t n = series.size();
  if (n < 16) throw std::invalid_argument("block length: needs at least 16 samples");
  for (double v : series) {
    if (!std::isfinite(v)) throw std::invalid_argument("block length: a sample is not finite");
  }
  const double dn = static_cast<double>(n);
  const auto kn = static_cast<std::size_t>(std::max(5.0, std::ceil(std::sqrt(std::log10(dn)))));
  // The authors search the cut up to sqrt(n) + kn; a gyro's bias wander can
  // correlate longer than that on a record of 1 s rows (sqrt(12 600) = 112 s
  // against a wander of several hundred), so the search reaches n / 10.
  const std::size_t max_m = std::min(n / 2 - kn - 1, n / 10 + kn);
  const std::vector<double> r = autocovariance(series, std::min(n - 1, 2 * max_m + kn + 1));
  if (!(r[0] > 0.0)) return 1.0;  // a constant series: nothing to carry over
  const double threshold = 2.0 * std::sqrt(std::log10(dn) / dn);
  std::size_t m = max_m;
  for (std::size_t lag = 0; lag + kn <= max_m; ++lag) {
    bool quiet = true;
    for (std::size_t k = 1; k <= kn && quiet; ++k) quiet = std::fabs(r[lag + k] / r[0]) < threshold;
    if (quiet) {
      m = lag;
      break;
    }
  }
  const std::size_t big_m = std::max<std::size_t>(1, 2 * m);
  double g = 0.0;
  double spectrum0 = r[0];
  for (std::size_t k = 1; k <= big_m && k < r.size(); ++k) {
    const double w = flat_top(static_cast<double>(k) / static_cast<double>(big_m));
    g += 2.0 * static_cast<double>(k) * w * r[k];
    spectrum0 += 2.0 * w * r[k];
  }
  const double d = 4.0 / 3.0 * spectrum0 * spectrum0;
  if (!(d > 0.0)) return 1.0;
  const double b = std::cbrt(2.0 * g * g / d) * std::cbrt(dn);
  return std::clamp(b, 1.0, dn / 3.0);
}

}  // namespace gyrotc::stats
