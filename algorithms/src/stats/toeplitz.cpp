#include "gyrotc/algorithms/stats/toeplitz.hpp"

#include <cmath>

namespace gyrotc::stats {

ToeplitzInverse toeplitz_inverse(const Eigen::VectorXd& first_column) {
  ToeplitzInverse out;
  const Eigen::Index n = first_column.size();
  const double t0 = n > 0 ? first_column(0) : 0.0;
  if (n == 0 || !(t0 > 0.0) || !first_column.allFinite()) return out;
  // Normalised to a unit diagonal: T = t0 toeplitz(1, r_1 .. r_{n-1}).
  const Eigen::VectorXd r = first_column.tail(n - 1) / t0;
  double log_det = static_cast<double>(n) * std::log(t0);
  if (n == 1) {
    out.inverse = Eigen::MatrixXd::Constant(1, 1, 1.0 / t0);
    out.log_det = log_det;
    out.ok = true;
    return out;
  }
  // Durbin: y solves T_{n-1} y = -r (the order n-1 predictor); beta is the
  // prediction-error variance of each order, alpha the reflection coefficient.
  const Eigen::Index m = n - 1;
  Eigen::VectorXd y(m);
  Eigen::VectorXd z(m);
  y(0) = -r(0);
  double beta = 1.0;
  double alpha = -r(0);
  for (Eigen::Index k = 1; k < m; ++k) {
    beta *= 1.0 - alpha * alpha;
    if (!(beta > 0.0)) return out;
    log_det += std::log(beta);
    double dot = 0.0;
    for (Eigen::Index i = 0; i < k; ++i) dot += r(k - 1 - i) * y(i);
    alpha = -(r(k) + dot) / beta;
    for (Eigen::Index i = 0; i < k; ++i) z(i) = y(i) + alpha * y(k - 1 - i);
    y.head(k) = z.head(k);
    y(k) = alpha;
  }
  // The last order's error variance: 1 + r' y = det T_n / det T_{n-1}.
  const double last = 1.0 + r.dot(y);
  if (!(last > 0.0)) return out;
  log_det += std::log(last);
  // Trench: the inverse from the predictor, filled by symmetry and
  // persymmetry (B(i, j) = B(j, i) = B(n-1-j, n-1-i), 0-based).
  const double gamma = 1.0 / last;
  Eigen::VectorXd v(m);
  for (Eigen::Index i = 0; i < m; ++i) v(i) = gamma * y(m - 1 - i);
  Eigen::MatrixXd b(n, n);
  b(0, 0) = gamma;
  for (Eigen::Index j = 1; j < n; ++j) b(0, j) = v(m - j);
  for (Eigen::Index i = 1; i <= (n - 1) / 2; ++i) {
    for (Eigen::Index j = i; j < n - i; ++j) {
      b(i, j) = b(i - 1, j - 1) + (v(m - j) * v(m - i) - v(i - 1) * v(j - 1)) / gamma;
    }
  }
  for (Eigen::Index i = 0; i <= (n - 1) / 2; ++i) {
    for (Eigen::Index j = i; j < n - i; ++j) {
      b(j, i) = b(i, j);
      b(n - 1 - j, n - 1 - i) = b(i, j);
      b(n - 1 - i, n - 1 - j) = b(i, j);
    }
  }
  out.inverse = b / t0;
  out.log_det = log_det;
  out.ok = out.inverse.allFinite();
  return out;
}

}  // namespace gyrotc::stats
