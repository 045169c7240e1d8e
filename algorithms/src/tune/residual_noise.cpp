#include "gyrotc/algorithms/tune/residual_noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace gyrotc::tune {
namespace {

// R x for R_ts = phi^|t-s| (a first-order process of unit variance), by a
// forward and a backward filter: O(n) per column.
Eigen::MatrixXd apply_first_order(const Eigen::MatrixXd& x, double phi) {
  const Eigen::Index n = x.rows();
  Eigen::MatrixXd forward = x;
  Eigen::MatrixXd backward = x;
  for (Eigen::Index t = 1; t < n; ++t) forward.row(t) += phi * forward.row(t - 1);
  for (Eigen::Index t = n - 2; t >= 0; --t) backward.row(t) += phi * backward.row(t + 1);
  return forward + backward - x;
}

// sum_t sum_j a(t, j) (S_l b)(t, j), S_l the symmetric lag-l shift
// ((S_l b)_t = (b_{t+l} + b_{t-l}) / 2), without forming S_l b.
double lagged_product(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, Eigen::Index lag) {
  const Eigen::Index n = a.rows();
  if (lag >= n) return 0.0;
  return 0.5 * (a.topRows(n - lag).cwiseProduct(b.bottomRows(n - lag)).sum() +
                a.bottomRows(n - lag).cwiseProduct(b.topRows(n - lag)).sum());
}

// Q' S_l Q, the same way.
Eigen::MatrixXd lagged_gram(const Eigen::MatrixXd& q, Eigen::Index lag) {
  const Eigen::Index n = q.rows();
  if (lag == 0) return q.transpose() * q;
  if (lag >= n) return Eigen::MatrixXd::Zero(q.cols(), q.cols());
  const Eigen::MatrixXd half = 0.5 * (q.topRows(n - lag).transpose() * q.bottomRows(n - lag));
  return half + half.transpose();
}

// E[(Me)' S_l (Me)] for e ~ (0, C), M = I - QQ':
// tr(S_l C) - 2 tr(Q' C S_l Q) + tr((Q' S_l Q)(Q' C Q)), with CQ given.
double expected_lagged_sum(const Eigen::MatrixXd& q, Eigen::Index lag, double gamma_lag, const Eigen::MatrixXd& cq,
                           const Eigen::MatrixXd& qcq, const Eigen::MatrixXd& qsq) {
  return static_cast<double>(q.rows() - lag) * gamma_lag - 2.0 * lagged_product(cq, q, lag) + (qsq * qcq).trace();
}

}  // namespace

ResidualNoise fit_residual_noise(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual, NoiseParts parts) {
  const Eigen::Index n = jacobian.rows();
  const Eigen::Index k = jacobian.cols();
  // An orthonormal basis of the Jacobian's columns (scaled first: the
  // parameters' units differ by orders of magnitude).
  Eigen::MatrixXd scaled = jacobian;
  for (Eigen::Index j = 0; j < k; ++j) {
    const double norm = scaled.col(j).norm();
    if (norm > 0.0) scaled.col(j) /= norm;
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(scaled);
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(n, k);

  // Lags roughly evenly spaced in log up to a quarter of the record.
  std::vector<Eigen::Index> lags;
  for (double l = 0.0; l <= static_cast<double>(n) / 4.0; l = std::max(l + 1.0, std::round(l * 1.5))) {
    lags.push_back(static_cast<Eigen::Index>(l));
  }
  std::vector<double> observed;
  std::vector<Eigen::MatrixXd> qsq;
  for (Eigen::Index l : lags) {
    observed.push_back(lagged_product(residual, residual, l));
    qsq.push_back(lagged_gram(q, l));
  }
  // The white part's expected sums (C = I).
  std::vector<double> white;
  {
    const Eigen::MatrixXd qcq = Eigen::MatrixXd::Identity(k, k);
    for (std::size_t i = 0; i < lags.size(); ++i) {
      white.push_back(expected_lagged_sum(q, lags[i], lags[i] == 0 ? 1.0 : 0.0, q, qcq, qsq[i]));
    }
  }

  // The first-order part's expected sums for time constants from 1 row to
  // the record's length, 1.25x apart.
  std::vector<double> taus;
  std::vector<std::vector<double>> slows;
  for (double tau = 1.0; tau <= static_cast<double>(n); tau *= 1.25) {
    const double phi = std::exp(-1.0 / tau);
    const Eigen::MatrixXd cq = apply_first_order(q, phi);
    const Eigen::MatrixXd qcq = q.transpose() * cq;
    std::vector<double> slow;
    for (std::size_t i = 0; i < lags.size(); ++i) {
      slow.push_back(expected_lagged_sum(q, lags[i], std::pow(phi, static_cast<double>(lags[i])), cq, qcq, qsq[i]));
    }
    taus.push_back(tau);
    slows.push_back(std::move(slow));
  }

  // Nonnegative least squares over the columns (white, a part at taus[a],
  // optionally one at taus[b]): each subset of the columns solved
  // unconstrained, the best whose variances are all >= 0 kept. A subset
  // without the second part is solved once per first part, not once per pair.
  const auto m = static_cast<Eigen::Index>(lags.size());
  const Eigen::Map<const Eigen::VectorXd> y(observed.data(), m);
  ResidualNoise best;
  double best_cost = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd x(m, 3);
  // Columns 0: white, 1: slows[a], 2: slows[b]; `used` is a bit set of them.
  auto solve = [&](std::size_t a, std::optional<std::size_t> b, int used) {
    Eigen::Index cols = 0;
    std::array<int, 3> which{};
    for (int c = 0; c < 3; ++c) {
      if (!(used & (1 << c))) continue;
      const std::vector<double>& column = c == 0 ? white : slows[c == 1 ? a : *b];
      x.col(cols) = Eigen::Map<const Eigen::VectorXd>(column.data(), m);
      which[static_cast<std::size_t>(cols++)] = c;
    }
    const auto xs = x.leftCols(cols);
    const Eigen::VectorXd variance = xs.colPivHouseholderQr().solve(y);
    if (!variance.allFinite() || (variance.array() < 0.0).any()) return;
    const double cost = (y - xs * variance).squaredNorm();
    if (!(cost < best_cost)) return;
    best_cost = cost;
    best = {};
    for (Eigen::Index c = 0; c < cols; ++c) {
      switch (which[static_cast<std::size_t>(c)]) {
        case 0: best.white_var = variance(c); break;
        case 1: best.slow_var = variance(c); best.slow_tau_rows = taus[a]; break;
        default: best.slower_var = variance(c); best.slower_tau_rows = taus[*b]; break;
      }
    }
  };
  for (std::size_t a = 0; a < taus.size(); ++a) {
    // 1.25^2 apart at least: neighbours of the grid are nearly one column.
    const bool pairs = parts == NoiseParts::two;
    if (pairs && a + 2 >= taus.size()) continue;
    for (int used = 1; used < 4; ++used) solve(a, std::nullopt, used);
    if (!pairs) continue;
    for (std::size_t b = a + 2; b < taus.size(); ++b) {
      for (int used = 4; used < 8; ++used) solve(a, b, used);
    }
  }
  // A second part that came out 0 leaves the fit's one part as the first.
  if (best.slow_var == 0.0 && best.slower_var > 0.0) {
    std::swap(best.slow_var, best.slower_var);
    std::swap(best.slow_tau_rows, best.slower_tau_rows);
    best.slower_tau_rows = 0.0;
  }
  return best;
}

Eigen::MatrixXd noise_covariance(const Eigen::MatrixXd& jacobian, const Eigen::MatrixXd& inverse_normal,
                                 const ResidualNoise& noise) {
  // As a sum of Gram matrices, so that it stays positive semi-definite when
  // the parameters' scales differ by orders of magnitude: with G = J (J'J)^-1
  // and R = L L' (L the first-order filter from white noise,
  // x_t = phi x_{t-1} + sqrt(1 - phi^2) e_t), the sandwich is
  // white G'G + slow (L'G)'(L'G) (+ the same for the slower part).
  const Eigen::MatrixXd g = jacobian * inverse_normal;
  Eigen::MatrixXd covariance = noise.white_var * (g.transpose() * g);
  auto add_first_order = [&](double var, double tau_rows) {
    if (!(var > 0.0 && tau_rows > 0.0)) return;
    const double phi = std::exp(-1.0 / tau_rows);
    const Eigen::Index n = g.rows();
    Eigen::MatrixXd h = g;  // L'G: a backward filter, every row but the first scaled
    for (Eigen::Index t = n - 2; t >= 0; --t) h.row(t) += phi * h.row(t + 1);
    h.bottomRows(n - 1) *= std::sqrt(1.0 - phi * phi);
    covariance += var * (h.transpose() * h);
  };
  add_first_order(noise.slow_var, noise.slow_tau_rows);
  add_first_order(noise.slower_var, noise.slower_tau_rows);
  return covariance;
}

}  // namespace gyrotc::tune
