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

// Shrinking pattern search over (log ratio, log tau), moving (lr, lt): each
// round polls the eight neighbours at the current steps (the likelihood's
// long ridge, along wander variance / tau, runs diagonally) and moves to
// each that better(lr, lt) accepts; a round without a move halves the steps,
// down to 0.02 in log ratio.
template <class Better>
void pattern_search(double& lr, double& lt, double step_t, double lt_lo, double lt_hi, Better&& better) {
  double step_r = 0.25;
  while (step_r > 0.02) {
    bool moved = false;
    for (const auto& [dr, dt] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}, {1.0, 1.0}, {-1.0, -1.0},
                                 {1.0, -1.0}, {-1.0, 1.0}}) {
      const double r = std::clamp(lr + dr * step_r, -6.0, 6.0);
      const double t = std::clamp(lt + dt * step_t, lt_lo, lt_hi);
      if (better(r, t)) {
        lr = r;
        lt = t;
        moved = true;
      }
    }
    if (!moved) {
      step_r /= 2.0;
      step_t /= 2.0;
    }
  }
}

// The innovations of K columns at once. Each column's filter is a serial
// recursion bounded by its latency, not its arithmetic: K independent ones
// interleave in the pipeline. The same operations as one column at a time.
template <int K>
void whiten_columns(double* const* z, std::size_t n, const std::vector<double>& decay, const std::vector<double>& gain,
                    const std::vector<double>& inv_sd) {
  double m[K] = {};  // filtered wander estimate after the previous sample
  double largest[K] = {};
  for (std::size_t t = 0; t < n; ++t) {
    for (int k = 0; k < K; ++k) {
      const double predicted = t > 0 ? decay[t] * m[k] : 0.0;
      const double v = z[k][t] - predicted;
      m[k] = predicted + gain[t] * v;
      z[k][t] = v * inv_sd[t];
      largest[k] = std::max(largest[k], std::fabs(z[k][t]));
    }
  }
  for (int k = 0; k < K; ++k) {
    const double tiny = 1e-12 * largest[k];
    for (std::size_t t = 0; t < n; ++t) {
      if (std::fabs(z[k][t]) < tiny) z[k][t] = 0.0;
    }
  }
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
  double last_dt = -1.0;
  double phi = 0.0;
  double product = 1.0;
  for (std::size_t t = 0; t < n; ++t) {
    double predicted = q;
    if (t > 0) {
      const double dt = time_s[t] - time_s[t - 1];
      if (dt != last_dt) {  // a regular record pays for one exp
        phi = std::exp(-dt / tau);
        last_dt = dt;
      }
      decay_[t] = phi;
      predicted = phi * phi * p + q * (1.0 - phi * phi);
    }
    const double white = white_scale.empty() ? 1.0 : white_scale[t];
    const double f = predicted + white;
    const double inv_f = 1.0 / f;
    gain_[t] = predicted * inv_f;
    inv_sd_[t] = std::sqrt(inv_f);
    // The log of a running product, taken before it could leave the
    // doubles' range: one log per many samples instead of one each.
    product *= f;
    if (!(product > 1e-100 && product < 1e100)) {
      log_det_ += std::log(product);
      product = 1.0;
    }
    p = predicted * (1.0 - gain_[t]);
  }
  log_det_ += std::log(product);
}

void Whitener::apply(Eigen::Ref<Eigen::MatrixXd> columns) const {
  const auto n = static_cast<std::size_t>(columns.rows());
  constexpr Eigen::Index kBlock = 4;
  Eigen::Index j = 0;
  for (; j + kBlock <= columns.cols(); j += kBlock) {
    double* const z[kBlock] = {columns.col(j).data(), columns.col(j + 1).data(), columns.col(j + 2).data(),
                               columns.col(j + 3).data()};
    whiten_columns<kBlock>(z, n, decay_, gain_, inv_sd_);
  }
  for (; j < columns.cols(); ++j) {
    double* const z[1] = {columns.col(j).data()};
    whiten_columns<1>(z, n, decay_, gain_, inv_sd_);
  }
}

namespace {

// Design and data whitened under a noise model, and the log-determinant.
struct Whitened {
  Eigen::MatrixXd x;
  Eigen::VectorXd z;
  double log_det = 0.0;
};

// Into `out`, whose storage is reused: a search whitens the same design
// dozens of times, and a fresh megabyte copy each time cost its page faults,
// a third of the identify tests' time under the sanitizers.
void whiten(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
            std::span<const double> time_s, std::span<const double> white_scale, Whitened& out) {
  const Whitener w(noise, time_s, white_scale);
  out.x = design;
  out.z = data;
  out.log_det = w.log_det();
  w.apply(out.x);
  w.apply(out.z);
}

NoiseLikelihoods likelihoods(const Whitened& w) {
  const Eigen::Index n = w.z.size();
  const Eigen::Index p = w.x.cols();
  double log_det_normal = 0.0;
  double sse = w.z.squaredNorm();
  if (p > 0) {
    const ScaledNormal normal = scaled_normal(w.x);
    log_det_normal = normal.log_det();
    const Eigen::VectorXd rhs = normal.scale.asDiagonal() * (w.x.transpose() * w.z);
    sse = std::max(sse - rhs.dot(normal.ldlt.solve(rhs)), 1e-300);
  }
  const double dof = std::max(1.0, static_cast<double>(n - p));
  const double nd = static_cast<double>(n);
  return {-0.5 * dof * std::log(sse / dof) - 0.5 * w.log_det - 0.5 * log_det_normal,
          -0.5 * nd * std::log(sse / nd) - 0.5 * w.log_det};
}

}  // namespace

GlsFit fit_gls(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
               std::span<const double> time_s, std::span<const double> white_scale) {
  Whitened w;
  whiten(data, design, noise, time_s, white_scale, w);
  const auto& [x, z, log_det] = w;
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
  if (best_lr <= kNoWander) return result();
  pattern_search(best_lr, best_lt, (lt_hi - lt_lo) / 20.0, lt_lo, lt_hi, consider);
  return result();
}

NoiseLikelihoods noise_likelihoods(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
                                   std::span<const double> time_s, std::span<const double> white_scale) {
  Whitened w;
  whiten(data, design, noise, time_s, white_scale, w);
  return likelihoods(w);
}

WanderNoise refine_wander_noise_restricted(const Eigen::VectorXd& data, const Eigen::MatrixXd& design,
                                           std::span<const double> time_s, std::span<const double> white_scale,
                                           double tau_min_s, double tau_max_s, const WanderNoise& start) {
  if (!(start.wander_var > 0.0) || !(start.white_var > 0.0) || !(tau_max_s > tau_min_s)) return start;
  const double lt_lo = std::log10(tau_min_s);
  const double lt_hi = std::log10(tau_max_s);
  double best_lr = std::log10(start.wander_var / start.white_var);
  double best_lt = std::clamp(std::log10(start.tau_s), lt_lo, lt_hi);
  Whitened w;
  const auto evaluate = [&](double lr, double lt) {
    whiten(data, design, relative_noise(lr, lt), time_s, white_scale, w);
    return likelihoods(w);
  };
  const NoiseLikelihoods at_start = evaluate(best_lr, best_lt);
  double best = at_start.restricted;
  const double min_full = at_start.full - kFullLikelihoodDrop;
  pattern_search(best_lr, best_lt, (lt_hi - lt_lo) / 20.0, lt_lo, lt_hi, [&](double lr, double lt) {
    const NoiseLikelihoods v = evaluate(lr, lt);
    if (!(v.restricted > best + 1e-9 && v.full >= min_full)) return false;
    best = v.restricted;
    return true;
  });
  return relative_noise(best_lr, best_lt);  // white variance 1: a ratio and a tau
}

}  // namespace gyrotc::identify
