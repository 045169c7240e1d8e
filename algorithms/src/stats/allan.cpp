#include "gyrotc/algorithms/stats/allan.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

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

namespace {

// The terms of the fit: tau^-2 (quantisation), tau^-1 (angle random walk),
// tau^0 (flicker), tau^1 (rate random walk), tau^2 (rate ramp).
constexpr int kTerms = 5;
constexpr std::array<double, kTerms> kPowers{-2.0, -1.0, 0.0, 1.0, 2.0};

// Weighted least squares of AVAR(tau) = sum_j c_j tau^p_j over the reliable
// points with every c_j >= 0 (IEEE 952 Annex C.2), by trying each subset of
// terms (2^5 small systems) and keeping the feasible one with the least
// residual. Each point is weighted by 1 / (model AVAR * relative error)^2:
// first with the measured AVAR as the model, then twice with the fit's own,
// so points that happen to fall low do not pull the fit down.
std::array<double, kTerms> fit_terms(const std::vector<AllanPoint>& points, double min_clusters) {
  std::vector<const AllanPoint*> used;
  for (const auto& p : points) {
    if (p.clusters >= min_clusters && p.adev > 0.0) used.push_back(&p);
  }
  std::array<double, kTerms> best{};
  if (used.empty()) return best;
  std::vector<double> scale(used.size());
  for (std::size_t i = 0; i < used.size(); ++i) scale[i] = used[i]->adev * used[i]->adev;
  for (int pass = 0; pass < 3; ++pass) {
    double best_cost = std::numeric_limits<double>::infinity();
    std::array<double, kTerms> pass_best{};
    for (unsigned mask = 1; mask < (1u << kTerms); ++mask) {
      std::vector<int> terms;
      for (int j = 0; j < kTerms; ++j) {
        if ((mask >> j) & 1u) terms.push_back(j);
      }
      const auto t = static_cast<Eigen::Index>(terms.size());
      if (static_cast<std::size_t>(t) > used.size()) continue;
      Eigen::MatrixXd a(static_cast<Eigen::Index>(used.size()), t);
      Eigen::VectorXd b(static_cast<Eigen::Index>(used.size()));
      for (std::size_t i = 0; i < used.size(); ++i) {
        const auto& p = *used[i];
        const double e = 1.0 / std::sqrt(2.0 * (p.clusters - 1.0));
        // AVAR's relative error is about twice the deviation's.
        const double w = 1.0 / (scale[i] * 2.0 * e);
        const auto r = static_cast<Eigen::Index>(i);
        for (Eigen::Index c = 0; c < t; ++c) {
          a(r, c) = w * std::pow(p.tau_s, kPowers[static_cast<std::size_t>(terms[static_cast<std::size_t>(c)])]);
        }
        b(r) = w * p.adev * p.adev;
      }
      const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
      if ((x.array() < 0.0).any() || !x.allFinite()) continue;
      const double cost = (a * x - b).squaredNorm();
      if (cost < best_cost) {
        best_cost = cost;
        pass_best.fill(0.0);
        for (Eigen::Index c = 0; c < t; ++c) pass_best[static_cast<std::size_t>(terms[static_cast<std::size_t>(c)])] = x(c);
      }
    }
    best = pass_best;
    for (std::size_t i = 0; i < used.size(); ++i) {
      double model = 0.0;
      for (std::size_t j = 0; j < kTerms; ++j) model += best[j] * std::pow(used[i]->tau_s, kPowers[j]);
      if (model > 0.0) scale[i] = model;
    }
  }
  return best;
}

SlopeLine line_of(double slope, double ref_tau_s, double value) {
  SlopeLine line;
  line.slope = slope;
  line.ref_tau_s = ref_tau_s;
  line.value_at_ref = value;
  line.valid = true;
  return line;
}

}  // namespace

AllanResult allan_deviation(std::span<const double> rate, double rate_hz, const AllanOptions& options) {
  const std::size_t n = rate.size();
  if (n < 2) throw std::invalid_argument("allan: need at least 2 samples");
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("allan: rate_hz must be positive");
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
    const double e = 1.0 / std::sqrt(2.0 * (p.clusters - 1.0));
    p.ci_low = std::max(0.0, p.adev * (1.0 - e));
    p.ci_high = p.adev * (1.0 + e);
    result.points.push_back(p);
  }

  const auto c = fit_terms(result.points, options.fit_min_clusters);
  bool any = false;
  for (double v : c) any = any || v > 0.0;
  if (any) {
    // AVAR = N^2 / tau (N at tau = 1 s); AVAR = K^2 tau / 3 (K at tau = 3 s).
    result.arw = line_of(-0.5, 1.0, std::sqrt(c[1]));
    result.rrw = line_of(0.5, 3.0, std::sqrt(3.0 * c[3]));
  }
  SlopeLine b;
  b.value_at_ref = std::numeric_limits<double>::infinity();
  for (const auto& p : result.points) {
    if (p.clusters >= options.fit_min_clusters && p.adev < b.value_at_ref) {
      b.value_at_ref = p.adev;
      b.ref_tau_s = p.tau_s;
      b.valid = true;
    }
  }
  // sqrt(2 ln 2 / pi) = 0.664: the flicker floor's ratio (IEEE 952 C.1.3).
  b.value_at_ref = b.valid ? b.value_at_ref / 0.664 : 0.0;
  result.bias_instability = b;
  return result;
}

}  // namespace gyrotc::stats
