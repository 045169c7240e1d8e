#pragma once

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

FitErrors fit_errors(std::span<const double> in_sample_residuals, std::span<const double> loo_residuals);

}  // namespace gyrotc::fit
