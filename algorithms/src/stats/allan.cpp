#include "gyrotc/algorithms/stats/allan.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/stats/allan_edf.hpp"
#include "gyrotc/algorithms/stats/chi_square.hpp"

namespace gyrotc::stats {

std::vector<std::size_t> allan_cluster_sizes(std::size_t n, double points_per_decade) {
  if (!(points_per_decade > 0.0)) throw std::invalid_argument("allan: points_per_decade must be positive");
  std::vector<std::size_t> sizes;
  const std::size_t max_m = n / 2;
  for (int k = 0;; ++k) {
    const double m = std::round(std::pow(10.0, static_cast<double>(k) / points_per_decade));
    if (m > static_cast<double>(max_m)) break;
    const auto mi = static_cast<std::size_t>(m);
    if (sizes.empty() || sizes.back() != mi) sizes.push_back(mi);
  }
  // The longest cluster time (two clusters) closes the curve.
  if (max_m >= 1 && sizes.back() != max_m) sizes.push_back(max_m);
  return sizes;
}

AllanResult allan_deviation(std::span<const double> rate, double rate_hz, const AllanOptions& options) {
  const std::size_t n = rate.size();
  if (n < 2) throw std::invalid_argument("allan: need at least 2 samples");
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("allan: rate_hz must be positive");
  if (!(options.confidence > 0.0 && options.confidence < 1.0)) {
    throw std::invalid_argument("allan: confidence must lie in (0, 1)");
  }
  if (!(options.hadamard_decades >= 0.0) || !(options.discrepancy_correlation >= 0.0 && options.discrepancy_correlation <= 1.0)) {
    throw std::invalid_argument("allan: hadamard_decades must be >= 0 and discrepancy_correlation in [0, 1]");
  }
  if (options.walk_blocks != 0 && options.walk_blocks < 10) {
    throw std::invalid_argument("allan: walk_blocks must be 0 (off) or at least 10");
  }
  double mean = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(rate[i])) throw std::invalid_argument("allan: sample " + std::to_string(i) + " is not finite");
    mean += rate[i];
  }
  mean /= static_cast<double>(n);

  const double tau0 = 1.0 / rate_hz;
  // theta_k in sample units (tau0 factored out, see below).
  std::vector<double> theta(n + 1);
  theta[0] = 0.0;
  for (std::size_t i = 0; i < n; ++i) theta[i + 1] = theta[i] + (rate[i] - mean);

  AllanResult result;
  result.samples = n;
  result.rate_hz = rate_hz;
  const std::size_t count = n + 1;
  for (std::size_t m : allan_cluster_sizes(n, options.points_per_decade)) {
    const std::size_t terms = count - 2 * m;
    double sum = 0.0;
    for (std::size_t k = 0; k < terms; ++k) {
      const double d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
      sum += d * d;
    }
    // theta scaled by tau0 and tau = m tau0: the tau0^2 cancel.
    const double md = static_cast<double>(m);
    const double avar = sum / (2.0 * md * md * static_cast<double>(terms));
    AllanPoint p;
    p.m = m;
    p.tau_s = md * tau0;
    p.adev = std::sqrt(avar);
    p.clusters = static_cast<double>(n) / md;
    if (3 * m <= n) {
      const std::size_t h_terms = count - 3 * m;
      double h_sum = 0.0;
      for (std::size_t k = 0; k < h_terms; ++k) {
        const double d = theta[k + 3 * m] - 3.0 * theta[k + 2 * m] + 3.0 * theta[k + m] - theta[k];
        h_sum += d * d;
      }
      p.hdev = std::sqrt(h_sum / (6.0 * md * md * static_cast<double>(h_terms)));
    }
    result.points.push_back(p);
  }

  result.fit = fit_noise_terms(result.points, n, rate_hz, options, rate);
  // Each point's interval: chi-square with the EDF of the fitted mixture
  // (white rate noise alone when nothing could be fitted).
  const double tail = 0.5 * (1.0 - options.confidence);
  for (AllanPoint& p : result.points) {
    p.edf = result.fit.valid ? mixture_edf(result.fit, p.tau_s, p.m, n)
                             : overlapping_avar_edf(PowerLawNoise::white_rate, p.m, n);
    const double avar = p.adev * p.adev;
    p.ci_low = std::sqrt(avar * p.edf / chi_square_quantile(1.0 - tail, p.edf));
    p.ci_high = std::sqrt(avar * p.edf / chi_square_quantile(tail, p.edf));
  }
  return result;
}

}  // namespace gyrotc::stats
