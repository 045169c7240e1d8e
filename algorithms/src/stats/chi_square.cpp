#include "gyrotc/algorithms/stats/chi_square.hpp"

#include <cmath>
#include <stdexcept>

namespace gyrotc::stats {

namespace {

// Regularised lower incomplete gamma P(a, x) = gamma(a, x) / Gamma(a):
// its power series where it converges fast (x < a + 1), otherwise one minus
// the upper function's continued fraction, evaluated by Lentz's method
// (Abramowitz & Stegun 6.5.29 and 6.5.31).
double lower_regularised_gamma(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double scale = std::exp(a * std::log(x) - x - std::lgamma(a));
  if (x < a + 1.0) {
    double term = 1.0 / a;
    double sum = term;
    for (int k = 1; k < 10000 && std::fabs(term) > 1e-16 * std::fabs(sum); ++k) {
      term *= x / (a + k);
      sum += term;
    }
    return std::fmin(1.0, sum * scale);
  }
  constexpr double kTiny = 1e-300;
  double f = kTiny;
  double c = f;
  double d = 0.0;
  for (int k = 0; k < 10000; ++k) {
    // Terms of x + 1 - a - 1(1 - a)/(x + 3 - a - ...), written as b_k + a_k / (...).
    const double ak = k == 0 ? 1.0 : -k * (k - a);
    const double bk = x + 2.0 * k + 1.0 - a;
    d = bk + ak * d;
    d = std::fabs(d) < kTiny ? kTiny : d;
    c = bk + ak / c;
    c = std::fabs(c) < kTiny ? kTiny : c;
    d = 1.0 / d;
    const double step = c * d;
    f *= step;
    if (std::fabs(step - 1.0) < 1e-16) break;
  }
  return std::fmax(0.0, 1.0 - scale * f);
}

}  // namespace

double chi_square_cdf(double x, double dof) {
  if (!(dof > 0.0)) throw std::invalid_argument("chi-square: degrees of freedom must be positive");
  return lower_regularised_gamma(0.5 * dof, 0.5 * x);
}

double chi_square_quantile(double p, double dof) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument("chi-square quantile: p must lie in (0, 1)");
  if (!(dof > 0.0)) throw std::invalid_argument("chi-square: degrees of freedom must be positive");
  // Bracket on a log scale, then bisect: the cdf is monotonic, and 200
  // halvings of log x reach double precision from any bracket used here.
  double lo = -1.0;
  double hi = 1.0;
  while (chi_square_cdf(std::exp(lo), dof) > p) lo -= 4.0;
  while (chi_square_cdf(std::exp(hi), dof) < p) hi += 4.0;
  for (int it = 0; it < 200 && hi - lo > 1e-14; ++it) {
    const double mid = 0.5 * (lo + hi);
    (chi_square_cdf(std::exp(mid), dof) < p ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

}  // namespace gyrotc::stats
