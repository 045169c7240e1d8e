#pragma once

#include <Eigen/Dense>

// Symmetric positive-definite Toeplitz matrices (the covariance of a
// stationary series sampled at equal steps) in O(n^2) rather than O(n^3).
namespace gyrotc::stats {

struct ToeplitzInverse {
  Eigen::MatrixXd inverse;
  double log_det = 0.0;
  bool ok = false;  // false: not positive definite (or empty)
};

// The inverse and log-determinant of the symmetric Toeplitz matrix with
// first column t: Durbin's recursion for the reflection coefficients (the
// log-determinant is the sum of the logs of the prediction-error variances)
// and Trench's algorithm for the inverse (Golub & Van Loan, Matrix
// Computations, Algorithms 4.7.1 and 4.7.3).
ToeplitzInverse toeplitz_inverse(const Eigen::VectorXd& first_column);

}  // namespace gyrotc::stats
