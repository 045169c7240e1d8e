#include "gyrotc/algorithms/identify/residual_stats.hpp"

#include <algorithm>
#include <cmath>

namespace gyrotc::identify {
namespace {

// Regularised upper incomplete gamma Q(a, x): series below a + 1,
// continued fraction above (the usual split; both converge fast there).
double upper_gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double sum = 1.0 / a;
    double term = sum;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * 1e-15) break;
    }
    return std::clamp(1.0 - sum * std::exp(log_prefix), 0.0, 1.0);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < 1e-15) break;
  }
  return std::clamp(std::exp(log_prefix) * h, 0.0, 1.0);
}

// Regularised incomplete beta I_x(a, b) by Lentz's continued fraction,
// using the symmetry I_x(a, b) = 1 - I_{1-x}(b, a) where it converges slowly.
double incomplete_beta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  if (x > (a + 1.0) / (a + b + 2.0)) return 1.0 - incomplete_beta(b, a, 1.0 - x);
  const double log_prefix =
      std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double tiny = 1e-300;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m < 1000; ++m) {
    const double md = m;
    double num = md * (b - md) * x / ((a + 2.0 * md - 1.0) * (a + 2.0 * md));
    for (int half = 0; half < 2; ++half) {
      d = 1.0 + num * d;
      if (std::fabs(d) < tiny) d = tiny;
      c = 1.0 + num / c;
      if (std::fabs(c) < tiny) c = tiny;
      d = 1.0 / d;
      h *= d * c;
      num = -(a + md) * (a + b + md) * x / ((a + 2.0 * md) * (a + 2.0 * md + 1.0));
    }
    if (std::fabs(d * c - 1.0) < 1e-15) break;
  }
  return std::clamp(std::exp(log_prefix) * h / a, 0.0, 1.0);
}

double autocorrelation(std::span<const double> r, double mean, double var, std::size_t lag) {
  double s = 0.0;
  for (std::size_t i = lag; i < r.size(); ++i) s += (r[i] - mean) * (r[i - lag] - mean);
  return s / (static_cast<double>(r.size()) * var);
}

struct Moments {
  double mean = 0.0;
  double var = 0.0;  // population variance (divided by n)
};

Moments moments(std::span<const double> r) {
  Moments m;
  for (double v : r) m.mean += v;
  m.mean /= static_cast<double>(r.size());
  for (double v : r) m.var += (v - m.mean) * (v - m.mean);
  m.var /= static_cast<double>(r.size());
  return m;
}

}  // namespace

double chi_square_sf(double x, double dof) { return upper_gamma_q(0.5 * dof, 0.5 * x); }

double f_sf(double f, double dof1, double dof2) {
  if (!(f > 0.0)) return 1.0;
  return incomplete_beta(0.5 * dof2, 0.5 * dof1, dof2 / (dof2 + dof1 * f));
}

double ljung_box_p(std::span<const double> residual, std::size_t lags) {
  const std::size_t n = residual.size();
  if (n < 4) return 1.0;
  lags = std::clamp<std::size_t>(lags, 1, n / 2);
  const Moments m = moments(residual);
  if (m.var <= 0.0) return 1.0;
  const double nd = static_cast<double>(n);
  double q = 0.0;
  for (std::size_t k = 1; k <= lags; ++k) {
    const double rho = autocorrelation(residual, m.mean, m.var, k);
    q += rho * rho / (nd - static_cast<double>(k));
  }
  q *= nd * (nd + 2.0);
  return chi_square_sf(q, static_cast<double>(lags));
}

double long_run_variance_factor(std::span<const double> residual, std::size_t bandwidth) {
  const std::size_t n = residual.size();
  if (n < 4) return 1.0;
  const Moments m = moments(residual);
  if (m.var <= 0.0) return 1.0;
  if (bandwidth == 0) {
    bandwidth = static_cast<std::size_t>(4.0 * std::pow(static_cast<double>(n) / 100.0, 2.0 / 9.0));
  }
  bandwidth = std::clamp<std::size_t>(bandwidth, 1, n / 2);
  double factor = 1.0;
  for (std::size_t k = 1; k <= bandwidth; ++k) {
    const double weight = 1.0 - static_cast<double>(k) / static_cast<double>(bandwidth + 1);
    factor += 2.0 * weight * autocorrelation(residual, m.mean, m.var, k);
  }
  return std::max(1.0, factor);
}

std::size_t decorrelation_lag(std::span<const double> residual, double below, std::size_t max_lag) {
  if (residual.size() < 3) return 0;
  const Moments m = moments(residual);
  if (m.var <= 0.0) return 0;
  for (std::size_t lag = 1; lag < max_lag && lag < residual.size(); ++lag) {
    if (autocorrelation(residual, m.mean, m.var, lag) < below) return lag;
  }
  return 0;
}

double lag1_autocorrelation(std::span<const double> residual) {
  const std::size_t n = residual.size();
  if (n < 3) return 0.0;
  const Moments m = moments(residual);
  if (m.var <= 0.0) return 0.0;
  return std::clamp(autocorrelation(residual, m.mean, m.var, 1), 0.0, 0.99);
}

double effective_sample_size(std::size_t n, double rho) {
  return std::max(2.0, static_cast<double>(n) * (1.0 - rho) / (1.0 + rho));
}

}  // namespace gyrotc::identify
