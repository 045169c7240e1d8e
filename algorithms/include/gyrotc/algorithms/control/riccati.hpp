#pragma once

#include <Eigen/Dense>

// The discrete algebraic Riccati equation of LQ control and of the
// steady-state Kalman filter:
//   P = Q + A' P A - A' P B (R + B' P B)^-1 B' P A.
// Its solution gives the LQ gain K = (R + B' P B)^-1 B' P A (u = -K x), and,
// with (A', H', W, V), the Kalman filter's prior covariance.
namespace gyrotc::control {

// The stabilising solution P, by doubling until it settles (relative change
// below 1e-12). R must be positive definite. Throws std::invalid_argument
// when it does not settle within max_iterations doublings, or settles on a
// P whose gain leaves A - B K unstable (the pair is not stabilisable, or Q
// not positive semi-definite).
Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::MatrixXd& q,
                           const Eigen::MatrixXd& r, int max_iterations = 100);

// The largest magnitude of m's eigenvalues.
double spectral_radius(const Eigen::MatrixXd& m);

}  // namespace gyrotc::control
