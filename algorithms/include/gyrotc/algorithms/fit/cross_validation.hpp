#pragma once

#include <Eigen/Dense>
#include <functional>
#include <span>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

// Fits a model of a fixed structure to (temp_c, value) over the range
// [t_min_c, t_max_c] (the range of the whole data set, also in LOO folds, so a
// left-out end point is predicted by the fold's curve, not by clamping).
using Fitter = std::function<BiasModel(std::span<const double> temp_c, std::span<const double> value,
                                       double t_min_c, double t_max_c)>;

// Leave-one-out residuals by refitting without each point in turn:
// r[i] = value[i] - model_without_i(temp_c[i]).
std::vector<double> loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                  const Fitter& fitter);

// The points left out with each point i when its error is predicted: every
// point within block_c of temp_c[i] (i itself when block_c is 0). Bins a
// sweep crosses in a row share the gyro's correlated noise; leaving them out
// together keeps a fold from borrowing its held-out point's noise from them
// (h-block cross-validation, Burman, Chow & Nolan 1994).
std::vector<std::vector<std::size_t>> held_out_blocks(std::span<const double> temp_c, double block_c);

// Held-out residuals by refitting without each point's block in turn:
// r[i] = value[i] - model_without_block_i(temp_c[i]). A block that leaves
// fewer than min_kept points predicts the point as plain leave-one-out does.
std::vector<double> block_residuals(std::span<const double> temp_c, std::span<const double> value,
                                    const Fitter& fitter, double block_c, std::size_t min_kept);

// The same for a linear smoother (fitted = H y, its penalty fixed), from its
// in-sample residuals e = y - H y and the entries of H that the blocks need
// (hat(a, b) = H_ab): refitting without a block B changes the fit at B by the
// deletion formula, r_B = (I - H_BB)^-1 e_B, exact for least squares and
// penalised least squares alike. Each point's residual is its entry of its
// own block's r_B (blocks[i][0] is i).
std::vector<double> linear_smoother_block_residuals(const Eigen::VectorXd& residual,
                                                    const std::vector<std::vector<std::size_t>>& blocks,
                                                    const std::function<double(std::size_t, std::size_t)>& hat);

// Residuals value[i] - model(temp_c[i]).
std::vector<double> residuals(const BiasModel& model, std::span<const double> temp_c,
                              std::span<const double> value);

// Error figures of a fit, in the unit of the values.
struct FitErrors {
  double in_sample_max_abs = 0.0;
  double in_sample_rms = 0.0;
  double loo_max_abs = 0.0;
  double loo_rms = 0.0;
};

// A candidate's leave-one-out score: its effective number of parameters,
// the mean squared LOO residual and that mean's standard error
// (sd of the squared residuals / sqrt(n)).
struct CvScore {
  double dof = 0.0;
  double mse = 0.0;
  double se = 0.0;
};

CvScore cv_score(double dof, std::span<const double> loo_residuals);

// The one-standard-error rule (Breiman et al. 1984, Section 3.4.3; Hastie,
// Tibshirani & Friedman, Section 7.10): of the candidates whose LOO mean
// square lies within one standard error of the smallest, the one with the
// fewest effective parameters (then the smaller mean square). Differences
// inside that band are what the points cannot tell apart, and the simpler
// candidate is the less likely to owe its score to the noise. Returns the
// candidate's index; throws std::invalid_argument for an empty list.
std::size_t one_standard_error_choice(std::span<const CvScore> scores);

FitErrors fit_errors(std::span<const double> in_sample_residuals, std::span<const double> loo_residuals);

}  // namespace gyrotc::fit
