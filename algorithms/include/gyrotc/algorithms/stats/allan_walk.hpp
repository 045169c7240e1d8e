#pragma once

#include <array>
#include <cstddef>
#include <span>

// The rate random walk of a record by restricted maximum likelihood (REML)
// on the differences of its block means. The walk's information lies in
// the longest spans, where the Allan variance has a few strongly correlated
// estimates; the Gaussian likelihood of the block means uses all of it. Its
// standard error approaches the Cramer-Rao bound of tools/allan_study
// --bound (docs/ALLAN.md).
namespace gyrotc::stats {

struct WalkEstimate {
  double walk_coefficient = 0.0;     // Allan-variance coefficient of the random walk, K^2 / 3
  double flicker_coefficient = 0.0;  // of the bias instability estimated beside it (0 when held at 0)
  double relative_se = 0.0;          // standard error of walk_coefficient / walk_coefficient
  std::size_t differences = 0;       // block-mean differences used
  bool ok = false;                   // false: too few blocks, or the covariance was not positive definite
};

// The record is cut into `blocks` equal blocks (the last partial one
// dropped); d_k = (mean_{k+1} - mean_k) / sqrt 2, the non-overlapped second
// differences of the angle at the block length, whose mean square is the
// Allan variance there. They are Gaussian with mean mu (a rate ramp, R tau /
// sqrt 2, removed by REML) and the Toeplitz covariance
//   sum_j c_j S_j,   S_j from difference_covariance (allan_covariance.hpp),
// c the Allan-variance coefficients in PowerLawNoise order (allan_edf.hpp).
// Quantisation and white rate are held at c[0], c[1] (the short clusters
// pin them); the random walk is estimated from c[3] (> 0), and the flicker
// beside it when c[2] > 0 (else held at 0). Average-information REML
// (Fisher scoring with the observed-expected average of the information,
// Gilmour, Thompson & Cullis 1995) in O(blocks^2) per step through the
// Toeplitz inverse; the standard error from that information at the optimum.
WalkEstimate reml_random_walk(std::span<const double> rate, double rate_hz, const std::array<double, 4>& c,
                              std::size_t blocks);

}  // namespace gyrotc::stats
