#include "gyrotc/algorithms/identify/wander_noise.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "gyrotc/algorithms/identify/separable_fit.hpp"

namespace gyrotc::identify {
namespace {

// The noise model as a point of the search: log10 of wander/white variance
// ratio (kNoWander: none) and log10 tau.
constexpr double kNoWander = -99.0;

// How far the full likelihood may fall from the maximum-likelihood start
// while the restricted likelihood moves the wander: the 95 % region of two
// parameters (chi-square(2) 5.99 / 2).
constexpr double kFullLikelihoodDrop = 3.0;

WanderNoise relative_noise(double log_ratio, double log_tau) {
  return {1.0, log_ratio <= kNoWander ? 0.0 : std::pow(10.0, log_ratio), std::pow(10.0, log_tau)};
}

}  // namespace

Whitener::Whitener(const WanderNoise& noise, std::span<const double> time_s,
                   std::span<const double> white_scale) {
  const std::size_t n = time_s.size();
  decay_.resize(n);
  gain_.resize(n);
  inv_sd_.resize(n);
  // In units of the white variance.
  const double q = noise.white_var > 0.0 ? noise.wander_var / noise.white_var : 0.0;
  const double tau = std::max(noise.tau_s, 1e-9);
  double p = q;  // stationary start
  for (std::size_t t = 0; t < n; ++t) {
    double predicted = q;
    if (t > 0) {
      const double phi = std::exp(-(time_s[t] - time_s[t - 1]) / tau);
      decay_[t] = phi;
      predicted = phi * phi * p + q * (1.0 - phi * phi);
    }
    const double white = white_scale.empty() ? 1.0 : white_scale[t];
    const double f = predicted + white;
    gain_[t] = predicted / f;
    inv_sd_[t] = 1.0 / std::sqrt(f);
    log_det_ += std::log(f);
    p = predicted * (1.0 - gain_[t]);
  }
}

void Whitener::apply(Eigen::Ref<Eigen::MatrixXd> columns) const {
  const Eigen::Index n = columns.rows();
  for (Eigen::Index j = 0; j < columns.cols(); ++j) {
    double* z = columns.col(j).data();
    double m = 0.0;  // filtered wander estimate after the previous sample
    double largest = 0.0;
    for (Eigen::Index t = 0; t < n; ++t) {
      const auto i = static_cast<std::size_t>(t);
      const double predicted = t > 0 ? decay_[i] * m : 0.0;
      const double v = z[t] - predicted;
      m = predicted + gain_[i] * v;
      z[t] = v * inv_sd_[i];
      largest = std::max(largest, std::fabs(z[t]));
    }
    const double tiny = 1e-12 * largest;
    for (Eigen::Index t = 0; t < n; ++t) {
      if (std::fabs(z[t]) < tiny) z[t] = 0.0;
    }
  }
}

namespace {

// Design and data whitened under a noise model, and the log-determinant.
struct Whitened {
  Eigen::MatrixXd x;
  Eigen::VectorXd z;
  double log_det = 0.0;
};

Whitened whiten(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
                std::span<const double> time_s, std::span<const double> white_scale) {
  const Whitener w(noise, time_s, white_scale);
  Whitened out{design, data, w.log_det()};
  w.apply(out.x);
  w.apply(out.z);
  return out;
}

}  // namespace

GlsFit fit_gls(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
               std::span<const double> time_s, std::span<const double> white_scale) {
  const auto [x, z, log_det] = whiten(data, design, noise, time_s, white_scale);
  const Eigen::Index n = data.size();
  const Eigen::Index p = design.cols();
  GlsFit fit;
  if (p > 0) {
    fit.beta = solve_linear(x, z);
    fit.white_residual = z - x * fit.beta;
  } else {
    fit.beta = Eigen::VectorXd();
    fit.white_residual = z;
  }
  const double nd = static_cast<double>(n);
  const double sse = std::max(fit.white_residual.squaredNorm(), 1e-300);
  const double dof = std::max(1.0, nd - static_cast<double>(p));
  fit.white_var = sse / dof;
  fit.log_likelihood = -0.5 * nd * std::log(sse / nd) - 0.5 * log_det;
  return fit;
}

WanderNoise fit_wander_noise(const Eigen::VectorXd& residual, std::span<const double> time_s,
                             std::span<const double> white_scale, double tau_min_s, double tau_max_s,
                             const WanderNoise* start) {
  const Eigen::MatrixXd no_columns(residual.size(), 0);
  const auto evaluate = [&](double log_ratio, double log_tau) {
    return fit_gls(residual, no_columns, relative_noise(log_ratio, log_tau), time_s, white_scale);
  };
  double best_lr = kNoWander;
  double best_lt = std::log10(std::max(tau_min_s, 1e-9));
  GlsFit best = evaluate(best_lr, best_lt);
  const auto result = [&] {
    WanderNoise out = relative_noise(best_lr, best_lt);
    out.white_var = best.white_var;
    out.wander_var *= best.white_var;
    return out;
  };
  if (residual.size() < 8 || !(tau_max_s > tau_min_s)) return result();

  const double lt_lo = std::log10(tau_min_s);
  const double lt_hi = std::log10(tau_max_s);
  const auto consider = [&](double lr, double lt) {
    GlsFit f = evaluate(lr, lt);
    if (f.log_likelihood > best.log_likelihood + 1e-9) {
      best = std::move(f);
      best_lr = lr;
      best_lt = lt;
      return true;
    }
    return false;
  };
  // Grid over log ratio and log tau, and the start if given. The likelihood
  // has a long curved ridge (along wander variance / tau, what short stretches
  // see), so the grid is fine and the search below also moves diagonally.
  for (double lr = -3.0; lr <= 3.0 + 1e-9; lr += 0.5) {
    for (int k = 0; k <= 10; ++k) consider(lr, lt_lo + (lt_hi - lt_lo) * k / 10.0);
  }
  if (start != nullptr && start->wander_var > 0.0 && start->white_var > 0.0) {
    consider(std::log10(start->wander_var / start->white_var), std::clamp(std::log10(start->tau_s), lt_lo, lt_hi));
  }
  double step_r = 0.25;
  double step_t = (lt_hi - lt_lo) / 20.0;
  if (best_lr <= kNoWander) return result();
  // Shrinking pattern search.
  while (step_r > 0.02) {
    bool moved = false;
    for (const auto& [dr, dt] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}, {1.0, 1.0}, {-1.0, -1.0},
                                 {1.0, -1.0}, {-1.0, 1.0}}) {
      moved = consider(std::clamp(best_lr + dr * step_r, -6.0, 6.0), std::clamp(best_lt + dt * step_t, lt_lo, lt_hi)) ||
              moved;
    }
    if (!moved) {
      step_r /= 2.0;
      step_t /= 2.0;
    }
  }
  return result();
}

NoiseLikelihoods noise_likelihoods(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
                                   std::span<const double> time_s, std::span<const double> white_scale) {
  const auto [x, z, log_det] = whiten(data, design, noise, time_s, white_scale);
  const Eigen::Index n = data.size();
  const Eigen::Index p = design.cols();
  double log_det_normal = 0.0;
  double sse = z.squaredNorm();
  if (p > 0) {
    Eigen::MatrixXd normal = gram_matrix(x);
    Eigen::VectorXd scale(p);
    for (Eigen::Index j = 0; j < p; ++j) {
      const double norm = std::sqrt(normal(j, j));
      scale(j) = norm > 0.0 ? 1.0 / norm : 1.0;
      log_det_normal -= 2.0 * std::log(scale(j));
    }
    normal = scale.asDiagonal() * normal * scale.asDiagonal();
    normal.diagonal().array() += 1e-10;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
    for (Eigen::Index j = 0; j < p; ++j) log_det_normal += std::log(std::max(ldlt.vectorD()(j), 1e-300));
    const Eigen::VectorXd rhs = scale.asDiagonal() * (x.transpose() * z);
    sse = std::max(sse - rhs.dot(ldlt.solve(rhs)), 1e-300);
  }
  const double dof = std::max(1.0, static_cast<double>(n - p));
  const double nd = static_cast<double>(n);
  return {-0.5 * dof * std::log(sse / dof) - 0.5 * log_det - 0.5 * log_det_normal,
          -0.5 * nd * std::log(sse / nd) - 0.5 * log_det};
}

WanderNoise refine_wander_noise_restricted(const Eigen::VectorXd& data, const Eigen::MatrixXd& design,
                                           std::span<const double> time_s, std::span<const double> white_scale,
                                           double tau_min_s, double tau_max_s, const WanderNoise& start) {
  if (!(start.wander_var > 0.0) || !(start.white_var > 0.0) || !(tau_max_s > tau_min_s)) return start;
  const double lt_lo = std::log10(tau_min_s);
  const double lt_hi = std::log10(tau_max_s);
  double best_lr = std::log10(start.wander_var / start.white_var);
  double best_lt = std::clamp(std::log10(start.tau_s), lt_lo, lt_hi);
  const auto evaluate = [&](double lr, double lt) {
    return noise_likelihoods(data, design, relative_noise(lr, lt), time_s, white_scale);
  };
  const NoiseLikelihoods at_start = evaluate(best_lr, best_lt);
  double best = at_start.restricted;
  const double min_full = at_start.full - kFullLikelihoodDrop;
  double step_r = 0.25;
  double step_t = (lt_hi - lt_lo) / 20.0;
  while (step_r > 0.02) {
    bool moved = false;
    for (const auto& [dr, dt] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}, {1.0, 1.0}, {-1.0, -1.0},
                                 {1.0, -1.0}, {-1.0, 1.0}}) {
      const double lr = std::clamp(best_lr + dr * step_r, -6.0, 6.0);
      const double lt = std::clamp(best_lt + dt * step_t, lt_lo, lt_hi);
      const NoiseLikelihoods v = evaluate(lr, lt);
      if (v.restricted > best + 1e-9 && v.full >= min_full) {
        best = v.restricted;
        best_lr = lr;
        best_lt = lt;
        moved = true;
      }
    }
    if (!moved) {
      step_r /= 2.0;
      step_t /= 2.0;
    }
  }
  return relative_noise(best_lr, best_lt);  // white variance 1: a ratio and a tau
}

}  // namespace gyrotc::identify
