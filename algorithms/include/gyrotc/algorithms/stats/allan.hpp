#pragma once

#include <cstddef>
#include <span>
#include <vector>

// Overlapping Allan deviation (IEEE Std 952-1997, Annex C) of a rate record
// sampled at a constant rate, and the standard noise coefficients read from
// it: angle random walk N, bias instability B, rate random walk K.
namespace gyrotc::stats {

struct AllanOptions {
  // Cluster times are log-spaced: round(10^(k / points_per_decade)) samples,
  // duplicates dropped. 10 per decade is finer than the octave (3.3 per decade).
  double points_per_decade = 10.0;
  // The N, B and K fits use only cluster times with at least this many
  // independent clusters (n / m): 30 keeps the 1-sigma relative error of each
  // point used <= 1 / sqrt(2 * 29) = 13 %.
  double fit_min_clusters = 30.0;
};

struct AllanPoint {
  double tau_s = 0.0;
  std::size_t m = 0;           // cluster size in samples
  double adev = 0.0;           // units of the input rate
  double ci_low = 0.0;         // adev * (1 - e), clamped at 0
  double ci_high = 0.0;        // adev * (1 + e)
  double clusters = 0.0;       // n / m independent clusters
};

// A noise term's slope line in log-log: adev = value_at_ref * (tau / ref_tau_s)^slope.
struct SlopeLine {
  double slope = 0.0;
  double ref_tau_s = 0.0;
  double value_at_ref = 0.0;   // N (at 1 s) or K (at 3 s); B: the minimum / 0.664
  bool valid = false;          // false when no point had enough clusters
};

struct AllanResult {
  std::size_t samples = 0;
  double rate_hz = 0.0;
  std::vector<AllanPoint> points;
  // N: slope -1/2 line read at tau = 1 s (units * sqrt(s), e.g. deg/sqrt(s)).
  SlopeLine arw;
  // B: flat minimum / 0.664 (= sqrt(2 ln 2 / pi), IEEE 952 C.1.3), units of the rate;
  // ref_tau_s is where the minimum lies.
  SlopeLine bias_instability;
  // K: slope +1/2 line read at tau = 3 s (units / sqrt(s)).
  SlopeLine rrw;
};

// Overlapping Allan deviation at the log-spaced cluster sizes 1 .. n/2, each
// in O(n) from the cumulative sum (the angle): with theta_k = tau0 * sum of the
// first k rates, N = n + 1 angles,
//   AVAR(m tau0) = sum_{k=0}^{N-2m-1} (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2
//                  / (2 (m tau0)^2 (N - 2m))                     (IEEE 952 Eq. C.4)
// The record's mean is removed first: it does not change AVAR and keeps the
// cumulative sum small, so the differences keep their precision.
//
// Confidence interval: the simple 1-sigma relative error of an Allan deviation
// estimated from K = n/m independent clusters, e = 1 / sqrt(2 (K - 1))
// (IEEE 952 Eq. C.8, after Lesage & Audoin 1973 for white frequency noise);
// it is exact for white noise and optimistic for random walk, whose
// overlapping estimate has fewer degrees of freedom.
//
// Fits: weighted non-negative least squares of the Allan variance to the sum
// of the standard terms, AVAR = Q2/tau^2 + N^2/tau + F + K^2 tau/3 + R2 tau^2
// (IEEE 952 Annex C.2), over the points with at least fit_min_clusters
// clusters. N is then the slope -1/2 line's value at tau = 1 s and K the slope
// +1/2 line's at tau = 3 s (the graphical reading, without its sensitivity to
// one noisy point); B = the curve's minimum (same points) / 0.664. A term the
// record does not show fits as 0.
//
// Throws std::invalid_argument for fewer than 2 samples, a non-positive or
// non-finite rate_hz, or a non-finite sample.
AllanResult allan_deviation(std::span<const double> rate, double rate_hz, const AllanOptions& options = {});

// The cluster sizes used for n samples: log-spaced, 1 .. n/2.
std::vector<std::size_t> allan_cluster_sizes(std::size_t n, double points_per_decade);

// Unit conversions for a rate in deg/s (N in deg/sqrt(s), K in deg/s/sqrt(s)).
constexpr double arw_deg_per_rt_h(double n_deg_per_rt_s) { return n_deg_per_rt_s * 60.0; }
constexpr double bias_deg_per_h(double b_dps) { return b_dps * 3600.0; }
constexpr double rrw_deg_per_h_per_rt_h(double k_dps_per_rt_s) { return k_dps_per_rt_s * 3600.0 * 60.0; }

}  // namespace gyrotc::stats
