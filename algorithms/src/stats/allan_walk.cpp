#include "gyrotc/algorithms/stats/allan_walk.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <limits>
#include <vector>

#include "gyrotc/algorithms/stats/allan_covariance.hpp"
#include "gyrotc/algorithms/stats/toeplitz.hpp"

namespace gyrotc::stats {

namespace {

// The REML criterion and the pieces a step needs, at one set of variance
// coefficients.
struct RemlState {
  double log_l = -std::numeric_limits<double>::infinity();
  Eigen::MatrixXd inverse;  // Sigma^-1
  Eigen::VectorXd a;        // Sigma^-1 1
  double w = 0.0;           // 1' Sigma^-1 1
  Eigen::VectorXd py;       // P d, P = Sigma^-1 - a a' / w
};

Eigen::VectorXd apply_p(const RemlState& s, const Eigen::VectorXd& v) {
  return s.inverse * v - s.a * (s.a.dot(v) / s.w);
}

// The average information, (S_j P d)' P (S_k P d) / 2, and the S_j P d it
// is made of (the score needs them too).
Eigen::MatrixXd average_information(const RemlState& s, const std::vector<Eigen::MatrixXd>& parts,
                                    std::vector<Eigen::VectorXd>& spy) {
  const auto p = static_cast<Eigen::Index>(parts.size());
  spy.clear();
  for (const Eigen::MatrixXd& part : parts) spy.push_back(part * s.py);
  Eigen::MatrixXd information(p, p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const Eigen::VectorXd pj = apply_p(s, spy[static_cast<std::size_t>(j)]);
    for (Eigen::Index k = 0; k < p; ++k) information(j, k) = 0.5 * pj.dot(spy[static_cast<std::size_t>(k)]);
  }
  return information;
}

RemlState evaluate(const Eigen::VectorXd& column, const Eigen::VectorXd& d) {
  RemlState s;
  ToeplitzInverse t = toeplitz_inverse(column);
  if (!t.ok) return s;
  s.inverse = std::move(t.inverse);
  s.a = s.inverse.rowwise().sum();  // symmetric: Sigma^-1 1
  s.w = s.a.sum();
  if (!(s.w > 0.0)) return s;
  const Eigen::VectorXd b = s.inverse * d;
  const double mu = s.a.dot(d) / s.w;
  s.py = b - s.a * mu;
  // -2 log L_REML = log det Sigma + log(1' Sigma^-1 1) + d' P d (+ const).
  s.log_l = -0.5 * (t.log_det + std::log(s.w) + d.dot(s.py));
  return s;
}

}  // namespace

WalkEstimate reml_random_walk(std::span<const double> rate, double rate_hz, const std::array<double, 4>& c,
                              std::size_t blocks) {
  WalkEstimate out;
  const std::size_t n = rate.size();
  if (blocks < 4 || n < blocks || !(c[3] > 0.0) || !(rate_hz > 0.0)) return out;
  const std::size_t m = n / blocks;
  const double tau0 = 1.0 / rate_hz;
  std::vector<double> means(blocks, 0.0);
  for (std::size_t b = 0; b < blocks; ++b) {
    double sum = 0.0;
    for (std::size_t i = b * m; i < (b + 1) * m; ++i) sum += rate[i];
    means[b] = sum / static_cast<double>(m);
  }
  const auto nd = static_cast<Eigen::Index>(blocks - 1);
  Eigen::VectorXd d(nd);
  for (Eigen::Index k = 0; k < nd; ++k) {
    d(k) = (means[static_cast<std::size_t>(k) + 1] - means[static_cast<std::size_t>(k)]) / std::sqrt(2.0);
  }
  // First columns of the Toeplitz parts: fixed (quantisation, white rate)
  // and estimated (random walk, then flicker if it is estimated).
  const VarianceEstimate e{m, 2};
  Eigen::VectorXd fixed = Eigen::VectorXd::Zero(nd);
  std::vector<Eigen::VectorXd> parts;
  parts.emplace_back(nd);
  const bool flicker = c[2] > 0.0;
  if (flicker) parts.emplace_back(nd);
  for (Eigen::Index h = 0; h < nd; ++h) {
    const std::array<double, 4> lag = difference_covariance(e, e, static_cast<double>(h) * static_cast<double>(m), tau0);
    fixed(h) = c[0] * lag[0] + c[1] * lag[1];
    parts[0](h) = lag[3];
    if (flicker) parts[1](h) = lag[2];
  }
  const auto p = static_cast<Eigen::Index>(parts.size());
  // Dense copies of the parts, for products with vectors.
  std::vector<Eigen::MatrixXd> dense;
  for (const Eigen::VectorXd& part : parts) {
    Eigen::MatrixXd s(nd, nd);
    for (Eigen::Index i = 0; i < nd; ++i) {
      for (Eigen::Index j = 0; j < nd; ++j) s(i, j) = part(std::abs(i - j));
    }
    dense.push_back(std::move(s));
  }
  Eigen::VectorXd theta(p);
  theta(0) = c[3];
  if (flicker) theta(1) = c[2];
  auto column = [&](const Eigen::VectorXd& th) {
    Eigen::VectorXd col = fixed;
    for (Eigen::Index j = 0; j < p; ++j) col += th(j) * parts[static_cast<std::size_t>(j)];
    return col;
  };
  RemlState state = evaluate(column(theta), d);
  if (!std::isfinite(state.log_l)) return out;
  std::vector<Eigen::VectorXd> spy;
  bool converged = false;
  for (int iteration = 0; iteration < 100 && !converged; ++iteration) {
    const Eigen::MatrixXd information = average_information(state, dense, spy);
    // Score: (d' P S_j P d - tr(P S_j)) / 2, with
    // tr(P S_j) = tr(Sigma^-1 S_j) - a' S_j a / w.
    Eigen::VectorXd score(p);
    for (Eigen::Index j = 0; j < p; ++j) {
      const Eigen::MatrixXd& s = dense[static_cast<std::size_t>(j)];
      const double trace = state.inverse.cwiseProduct(s).sum() - state.a.dot(s * state.a) / state.w;
      score(j) = 0.5 * (state.py.dot(spy[static_cast<std::size_t>(j)]) - trace);
    }
    const Eigen::VectorXd step = information.ldlt().solve(score);
    if (!step.allFinite()) return out;
    // Halve the step until the coefficients stay positive and the criterion
    // does not fall.
    double length = 1.0;
    bool moved = false;
    for (int halving = 0; halving < 40; ++halving, length *= 0.5) {
      const Eigen::VectorXd next = theta + length * step;
      if ((next.array() <= 0.0).any()) continue;
      RemlState trial = evaluate(column(next), d);
      if (trial.log_l >= state.log_l - 1e-12 * std::fabs(state.log_l)) {
        converged = ((length * step).array().abs() <= 1e-7 * theta.array()).all();
        theta = next;
        state = std::move(trial);
        moved = true;
        break;
      }
    }
    if (!moved) break;
  }
  // The information at the optimum, for the standard error.
  const Eigen::MatrixXd covariance = average_information(state, dense, spy).ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  if (!covariance.allFinite() || !(covariance(0, 0) > 0.0)) return out;
  out.walk_coefficient = theta(0);
  out.flicker_coefficient = flicker ? theta(1) : 0.0;
  out.relative_se = std::sqrt(covariance(0, 0)) / theta(0);
  out.differences = static_cast<std::size_t>(nd);
  out.ok = true;
  return out;
}

}  // namespace gyrotc::stats
