#pragma once
// The noise under a least-squares fit's residual, and the covariance of the
// fit's parameters it implies.
//
// A fit with parameters that act slowly (a shell of minutes, a loss of an
// hour) takes part of a slow sensor noise into its own curve: the residual
// shows less slow noise than the record had, and a long-run covariance read
// from the residual alone (Newey-West) is low by a factor 1.5-4.6 on the
// records of tests/algorithms/tune/standard_error_coverage_test.cpp. So the
// noise is modelled (white + one first-order part) and its parameters are
// those whose residual, after the same projection, would show the
// autocovariances the record's residual shows. A record can carry noise on
// two time scales (a DS18B20's 1/16 C steps, which hold while the casing
// sits still, under a sensor's own faster noise): NoiseParts::two fits a
// second first-order part.
#include <Eigen/Dense>

namespace gyrotc::tune {

struct ResidualNoise {
  double white_var = 0.0;      // variance of the white part (the DS18B20's steps, fast noise)
  double slow_var = 0.0;       // stationary variance of the first-order part
  double slow_tau_rows = 0.0;  // its time constant, in rows
  // A second first-order part (NoiseParts::two; 0 otherwise), slower than
  // the first.
  double slower_var = 0.0;
  double slower_tau_rows = 0.0;
};

enum class NoiseParts : unsigned char { one, two };

// Fits ResidualNoise to the residual of a least-squares fit whose Jacobian
// is `jacobian` (rows = the residual's): the expected autocovariances of
// (I - P) e, P the projection on the Jacobian's columns and e the modelled
// noise, matched to the residual's at lags 0..n/4 (least squares over a
// grid of time constants, variances >= 0). With NoiseParts::two, every pair
// of time constants of the grid at least 1.5x apart is tried (a part may
// come out 0).
ResidualNoise fit_residual_noise(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual,
                                 NoiseParts parts = NoiseParts::one);

// The covariance of the parameters under that noise: the sandwich
// (J'J)^-1 J' C J (J'J)^-1, C = white I + slow R(tau) + slower R(tau'). inverse_normal is
// (J'J)^-1.
Eigen::MatrixXd noise_covariance(const Eigen::MatrixXd& jacobian, const Eigen::MatrixXd& inverse_normal,
                                 const ResidualNoise& noise);

}  // namespace gyrotc::tune
