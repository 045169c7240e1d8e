#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

// Training options of the seed's BP network (Section 4.1: 3 hidden layers of
// 10 tansig neurons, linear output, MATLAB trainlm). Stopping rules follow
// trainlm's defaults where the seed names none.
struct BpTrainOptions {
  std::vector<int> hidden = {10, 10, 10};  // Section 4.1: three hidden layers of ten neurons
  std::uint64_t seed = 1;                   // the validation split and the restarts' initial weights
  // Trainings from different initial weights on the same validation split;
  // the one with the lowest error on the held-out points is kept (the
  // training error when validation_fraction is 0). Guards against an unlucky
  // start of an over-parameterised network (3 x 10 has 251 parameters for
  // Table 2's 25 points) without letting the held-out points into the fit:
  // judged on all points, the restart that fits the training points hardest
  // would win, undoing the early stopping.
  int restarts = 3;
  int max_epochs = 300;
  double goal_mse = 1e-4;                   // Section 4.1: training goal 0.0001 (normalised outputs)
  // Early stopping: this fraction of the interior points (never the two end
  // temperatures) is held out; training stops after max_fail epochs without a
  // new best validation error and returns the best weights (trainlm: 6).
  double validation_fraction = 0.15;
  int max_fail = 6;
  double mu_initial = 1e-3;  // trainlm mu, mu_dec, mu_inc, mu_max
  double mu_decrease = 0.1;
  double mu_increase = 10.0;
  double mu_max = 1e10;
};

struct BpTrainResult {
  BpNetwork net;
  int epochs = 0;                // of the kept training
  std::uint64_t seed_used = 0;   // initial-weights seed of the kept training
  double train_mse = 0.0;       // normalised units
  double validation_mse = 0.0;  // normalised units; 0 without a validation split
  std::size_t validation_points = 0;  // held out for early stopping and the choice of restart
  std::string stop_reason;      // "goal", "validation", "max_epochs", "mu_max"
};

// Trains a network on (temp_c, value) with Levenberg-Marquardt; the result is
// bit-for-bit the same for the same inputs, options and seed on one platform
// (own uniform generator, no std distributions). Input normalisation uses
// [t_min_c, t_max_c] (data range when t_min_c >= t_max_c).
// Throws std::invalid_argument for bad options or fewer than 3 points.
BpTrainResult train_bp_network(std::span<const double> temp_c, std::span<const double> value,
                               const BpTrainOptions& options, double t_min_c = 0.0,
                               double t_max_c = 0.0);

}  // namespace gyrotc::fit
