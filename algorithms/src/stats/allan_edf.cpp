#include "gyrotc/algorithms/stats/allan_edf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace gyrotc::stats {

namespace {

int alpha_of(PowerLawNoise noise) {
  switch (noise) {
    case PowerLawNoise::quantisation: return 2;
    case PowerLawNoise::white_rate: return 0;
    case PowerLawNoise::flicker_rate: return -1;
    case PowerLawNoise::random_walk_rate: return -2;
  }
  return 0;
}

// Greenhall & Riley 2003, Eq. 7: the generalised autocovariance of the
// phase for S_y ~ f^alpha, up to a constant factor.
double sw(double t, int alpha) {
  const double a = std::fabs(t);
  switch (alpha) {
    case 2: return -a;
    case 1: return a == 0.0 ? 0.0 : t * t * std::log(a);
    case 0: return a * a * a;
    case -1: return a == 0.0 ? 0.0 : t * t * t * t * std::log(a);
    case -2: return a * a * a * a * a;
    case -3: return a == 0.0 ? 0.0 : std::pow(t, 6) * std::log(a);
    default: return std::pow(a, 7);
  }
}

constexpr double kInfinite = std::numeric_limits<double>::infinity();

// Eq. 8: with filter factor F (F = m for the unmodified variance, infinite
// for its limit of large m).
double sx(double t, double f, int alpha) {
  if (std::isinf(f)) return sw(t, alpha + 2);
  return f * f * (2.0 * sw(t, alpha) - sw(t - 1.0 / f, alpha) - sw(t + 1.0 / f, alpha));
}

// Eq. 9 for the second difference (d = 2, the Allan variance).
double sz(double t, double f, int alpha) {
  return 6.0 * sx(t, f, alpha) - 4.0 * sx(t - 1.0, f, alpha) - 4.0 * sx(t + 1.0, f, alpha) +
         sx(t - 2.0, f, alpha) + sx(t + 2.0, f, alpha);
}

// Eq. 10: the basic sum, from which 1/EDF = BasicSum / (sz(0)^2 M).
double basic_sum(double j_terms, double m_terms, double s, double f, int alpha) {
  const double first = sz(0.0, f, alpha);
  double sum = first * first;
  const double last = sz(j_terms / s, f, alpha);
  sum += (1.0 - j_terms / m_terms) * last * last;
  for (int j = 1; j < static_cast<int>(j_terms); ++j) {
    const double z = sz(j / s, f, alpha);
    sum += 2.0 * (1.0 - j / m_terms) * z * z;
  }
  return sum;
}

// Greenhall & Riley Table 2, d = 2: 1/EDF = (1/r)(a0 - a1/r) for many clusters.
void table2(int alpha, double& a0, double& a1) {
  switch (alpha) {
    case 0: a0 = 2.0 / 3.0; a1 = 1.0 / 3.0; return;
    case -1: a0 = 0.852; a1 = 0.375; return;
    default: a0 = 1.079; a1 = 0.368; return;  // -2
  }
}

}  // namespace

double overlapping_avar_edf(PowerLawNoise noise, std::size_t m, std::size_t samples) {
  if (m < 1 || 2 * m > samples) throw std::invalid_argument("allan edf: need 1 <= m <= samples / 2");
  const int alpha = alpha_of(noise);
  const auto md = static_cast<double>(m);
  const double n_phase = static_cast<double>(samples) + 1.0;
  // Overlapping (stride S = m), unmodified (F = m) second differences: the
  // filter spans L = 2m + 1 phase points, M = N - 2m terms, r = M / m.
  const double s = md;
  const double terms = n_phase - 2.0 * md;
  const double j_terms = std::min(terms, 3.0 * md);
  constexpr double kJmax = 100.0;
  if (alpha == 2) {
    // White angle noise: the second differences D_k correlate only at lags
    // 0, m, 2m (6, -4, 1 times the variance), so the basic sum is exact in
    // closed form: nu = 36 M^2 / (36 M + 32 (M - m)+ + 2 (M - 2m)+), the
    // finite-r form of Greenhall's case 4 (1/nu -> (35/18) / M).
    const double lag1 = std::max(0.0, terms - md);
    const double lag2 = std::max(0.0, terms - 2.0 * md);
    return 36.0 * terms * terms / (36.0 * terms + 32.0 * lag1 + 2.0 * lag2);
  }
  // Case 2 (alpha <= 0, unmodified), with the phase point-sampled: the
  // angle is the exact running sum of the rate samples, so no averaging
  // filter acts on it (F infinite; Greenhall's F = m models a counter that
  // averages the phase, which differs at small m: for white rate noise at
  // m = 1 the exact EDF is 2M/3, F = m gives 0.78 M).
  if (j_terms <= kJmax) {
    const double z0 = sz(0.0, kInfinite, alpha);
    return z0 * z0 * terms / basic_sum(j_terms, terms, s, kInfinite, alpha);
  }
  const double r = terms / s;
  if (r > 3.0) {
    double a0 = 0.0;
    double a1 = 0.0;
    table2(alpha, a0, a1);
    return 1.0 / ((1.0 / r) * (a0 - a1 / r));
  }
  const double m_prime = kJmax / r;
  const double z0 = sz(0.0, kInfinite, alpha);
  return z0 * z0 * kJmax / basic_sum(kJmax, kJmax, m_prime, kInfinite, alpha);
}

double overlapping_avar_edf_simple(PowerLawNoise noise, std::size_t m, std::size_t samples) {
  if (m < 1 || 2 * m > samples) throw std::invalid_argument("allan edf: need 1 <= m <= samples / 2");
  const auto md = static_cast<double>(m);
  const double n = static_cast<double>(samples) + 1.0;  // phase points
  switch (noise) {
    case PowerLawNoise::quantisation: return (n + 1.0) * (n - 2.0 * md) / (2.0 * (n - md));
    case PowerLawNoise::white_rate:
      return (3.0 * (n - 1.0) / (2.0 * md) - 2.0 * (n - 2.0) / n) * 4.0 * md * md / (4.0 * md * md + 5.0);
    case PowerLawNoise::flicker_rate:
      return m == 1 ? 2.0 * (n - 2.0) * (n - 2.0) / (2.3 * n - 4.9) : 5.0 * n * n / (4.0 * md * (n + 3.0 * md));
    case PowerLawNoise::random_walk_rate:
      return (n - 2.0) / md * ((n - 1.0) * (n - 1.0) - 3.0 * md * (n - 1.0) + 4.0 * md * md) / ((n - 3.0) * (n - 3.0));
  }
  return n - 1.0;
}

}  // namespace gyrotc::stats
