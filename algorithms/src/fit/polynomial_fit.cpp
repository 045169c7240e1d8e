#include "gyrotc/algorithms/fit/polynomial_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/fit/cross_validation.hpp"

namespace gyrotc::fit {

namespace {

void check_input(std::span<const double> temp_c, std::span<const double> value, int order,
                 std::size_t min_points) {
  if (order < 0) throw std::invalid_argument("polynomial order must be >= 0");
  if (temp_c.size() != value.size()) throw std::invalid_argument("temperature and value counts differ");
  if (temp_c.size() < min_points) {
    throw std::invalid_argument("order " + std::to_string(order) + " needs at least " +
                                std::to_string(min_points) + " points, got " +
                                std::to_string(temp_c.size()));
  }
  for (std::size_t i = 0; i < temp_c.size(); ++i) {
    if (!std::isfinite(temp_c[i]) || !std::isfinite(value[i])) {
      throw std::invalid_argument("non-finite value at point " + std::to_string(i));
    }
  }
}

Eigen::MatrixXd vandermonde(std::span<const double> temp_c, double center, double scale, int order) {
  const auto n = static_cast<Eigen::Index>(temp_c.size());
  Eigen::MatrixXd v(n, order + 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = (temp_c[static_cast<std::size_t>(i)] - center) / scale;
    double p = 1.0;
    for (int j = 0; j <= order; ++j) {
      v(i, j) = p;
      p *= x;
    }
  }
  return v;
}

}  // namespace

PolynomialFit fit_polynomial(std::span<const double> temp_c, std::span<const double> value,
                             int order, double t_min_c, double t_max_c) {
  check_input(temp_c, value, order, static_cast<std::size_t>(order) + 1);
  if (!(t_min_c < t_max_c)) {
    const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
    t_min_c = *lo;
    t_max_c = *hi;
  }
  if (!(t_min_c < t_max_c)) throw std::invalid_argument("all temperatures are equal");
  PolynomialFit fit;
  fit.poly.center_c = 0.5 * (t_min_c + t_max_c);
  fit.poly.scale_c = 0.5 * (t_max_c - t_min_c);
  fit.poly.t_min_c = t_min_c;
  fit.poly.t_max_c = t_max_c;
  const Eigen::MatrixXd v = vandermonde(temp_c, fit.poly.center_c, fit.poly.scale_c, order);
  const Eigen::Map<const Eigen::VectorXd> y(value.data(), static_cast<Eigen::Index>(value.size()));
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(v);
  if (qr.rank() < order + 1) {
    throw std::invalid_argument("order " + std::to_string(order) +
                                " needs at least " + std::to_string(order + 1) +
                                " distinct temperatures");
  }
  const Eigen::VectorXd a = qr.solve(y);
  fit.poly.coefficients_mv.assign(a.data(), a.data() + a.size());
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(v);
  const auto& s = svd.singularValues();
  fit.condition_number = s(0) / s(s.size() - 1);
  return fit;
}

std::vector<double> polynomial_loo_residuals(std::span<const double> temp_c,
                                             std::span<const double> value, int order, double block_c) {
  check_input(temp_c, value, order, static_cast<std::size_t>(order) + 2);
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  if (!(*lo < *hi)) throw std::invalid_argument("all temperatures are equal");
  const Eigen::MatrixXd v = vandermonde(temp_c, 0.5 * (*lo + *hi), 0.5 * (*hi - *lo), order);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(v);
  if (qr.rank() < order + 1) {
    throw std::invalid_argument("order " + std::to_string(order) + " needs at least " +
                                std::to_string(order + 1) + " distinct temperatures");
  }
  // Thin Q of V: fitted values Q Q'y, leverage h_ii = |row i of Q|^2.
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(v.rows(), v.cols());
  const Eigen::Map<const Eigen::VectorXd> y(value.data(), static_cast<Eigen::Index>(value.size()));
  const Eigen::VectorXd fitted = q * (q.transpose() * y);
  if (block_c > 0.0) {
    return linear_smoother_block_residuals(y - fitted, held_out_blocks(temp_c, block_c),
                                           [&q](std::size_t a, std::size_t b) {
                                             return q.row(static_cast<Eigen::Index>(a))
                                                 .dot(q.row(static_cast<Eigen::Index>(b)));
                                           });
  }
  std::vector<double> loo(temp_c.size());
  for (std::size_t i = 0; i < temp_c.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double h = q.row(row).squaredNorm();
    // h = 1 means the point alone determines the fit (never with distinct
    // temperatures and >= order + 2 points); guard against rounding.
    loo[i] = (value[i] - fitted(row)) / std::max(1.0 - h, 1e-12);
  }
  return loo;
}

}  // namespace gyrotc::fit
