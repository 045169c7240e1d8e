#pragma once

#include <Eigen/Dense>

#include <functional>
#include <vector>

// Least squares for models that are linear in most parameters and nonlinear
// in a few (time constants, activation energies): y = offset(theta) +
// X(theta) * beta. The linear amplitudes beta are solved exactly for every
// theta (variable projection); theta is searched on a coarse grid and then
// refined by Levenberg-Marquardt on the projected residual.
namespace gyrotc::identify {

struct SeparableModel {
  // Fills the design matrix (rows = samples) and the known offset for theta.
  std::function<void(const std::vector<double>& theta, Eigen::MatrixXd& design,
                      Eigen::VectorXd& offset)>
      evaluate;
  std::vector<double> theta_lower;  // physical bounds of theta (inclusive)
  std::vector<double> theta_upper;
  // Grid of starting points for theta; empty when theta is empty.
  std::vector<std::vector<double>> theta_grid;
};

struct SeparableFit {
  std::vector<double> theta;
  Eigen::VectorXd beta;
  Eigen::VectorXd prediction;
  Eigen::VectorXd residual;  // y - prediction
  double sse = 0.0;
  // Unscaled covariance (J^T J)^-1 of [beta; theta]; multiply by the
  // residual variance (and an autocorrelation inflation) for standard errors.
  Eigen::MatrixXd covariance_unscaled;
  bool theta_at_bound = false;
};

// The Cartesian product of per-parameter grids: the theta_grid of a model
// with several nonlinear parameters.
std::vector<std::vector<double>> grid_product(const std::vector<std::vector<double>>& axes);

// A^T A from the non-zeros of each row: the spline columns of a design are
// zero but for 4 per row, so this costs O(rows * nnz^2) instead of
// O(rows * cols^2), the difference between seconds and minutes on a day's
// record (and in Debug builds).
Eigen::MatrixXd gram_matrix(const Eigen::MatrixXd& design);

// A^T A with its columns scaled to unit norm and a tiny ridge, so nearly
// collinear columns (an empty spline interval) stay solvable, factorised:
// what the solves and the restricted likelihood's determinant share.
struct ScaledNormal {
  Eigen::VectorXd scale;              // 1 / each column's norm (1 for a zero column)
  Eigen::LDLT<Eigen::MatrixXd> ldlt;  // of diag(scale) A^T A diag(scale) + 1e-10 I
  // ln det A^T A (of the ridged matrix, unscaled).
  double log_det() const;
};
ScaledNormal scaled_normal(const Eigen::MatrixXd& design);

// Linear LS of y on design (columns scaled internally, tiny ridge so that
// empty spline intervals do not break the solve). Returns beta.
Eigen::VectorXd solve_linear(const Eigen::MatrixXd& design, const Eigen::VectorXd& y);

SeparableFit fit_separable(const Eigen::VectorXd& y, const SeparableModel& model);

// The Jacobian [design, d prediction / d theta] of the model at theta with
// linear parameters beta (finite steps kept inside the bounds); *at_bound is
// set when a theta lies within 1e-4 of its range from a bound.
Eigen::MatrixXd model_jacobian(const SeparableModel& model, const std::vector<double>& theta,
                               const Eigen::VectorXd& beta, bool* at_bound = nullptr);

// (J^T J)^-1 with columns scaled to unit norm and a tiny ridge.
Eigen::MatrixXd inverse_normal(const Eigen::MatrixXd& jacobian);

// Parameter i's standard error from a covariance: the square root of its
// diagonal element (0 where rounding left that element negative).
double standard_error(const Eigen::MatrixXd& covariance, Eigen::Index i);

// Only the linear part, theta fixed: for cross-validation refits.
Eigen::VectorXd predict_with_theta(const Eigen::VectorXd& y, const SeparableModel& model,
                                   const std::vector<double>& theta,
                                   const std::vector<bool>& train);

}  // namespace gyrotc::identify
