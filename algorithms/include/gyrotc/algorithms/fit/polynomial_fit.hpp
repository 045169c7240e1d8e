#pragma once

#include <span>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

struct PolynomialFit {
  Polynomial poly;
  // 2-norm condition number of the (centred, scaled) design matrix: how much
  // the fit amplifies noise in the data. Eq. 17's normal equations would
  // square it.
  double condition_number = 0.0;
};

// Least-squares polynomial of the given order through (temp_c, value) (seed
// Eq. 14-16), solved the numerically sound way: temperature centred on the
// middle of [t_min_c, t_max_c] and scaled by its half width, then a
// column-pivoting Householder QR of the Vandermonde matrix instead of the
// normal equations of Eq. 17. The fitted range is [t_min_c, t_max_c]; pass
// t_min_c >= t_max_c to use the range of the data.
// Throws std::invalid_argument for order < 0, fewer than order + 1 points,
// mismatched spans or non-finite values.
PolynomialFit fit_polynomial(std::span<const double> temp_c, std::span<const double> value,
                             int order, double t_min_c = 0.0, double t_max_c = 0.0);

// Leave-one-out residuals of that fit (value[i] minus the prediction of the
// polynomial fitted without point i), from one fit via the hat matrix:
// r_loo[i] = r[i] / (1 - h_ii). Needs at least order + 2 points. With
// block_c > 0, each point is predicted without every point within block_c of
// it (held_out_blocks, cross_validation.hpp).
std::vector<double> polynomial_loo_residuals(std::span<const double> temp_c,
                                             std::span<const double> value, int order, double block_c = 0.0);

}  // namespace gyrotc::fit
