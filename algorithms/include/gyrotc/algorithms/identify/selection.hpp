#pragma once

#include <Eigen/Dense>

#include <functional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/identification.hpp"
#include "gyrotc/algorithms/identify/separable_fit.hpp"
#include "gyrotc/algorithms/identify/wander_noise.hpp"

// The target-independent core of step 3 of the workflow: try each named
// effect on top of the current model, refit everything jointly, keep the best
// that passes every test (a nested-model test whose p-value scales with the
// number of independent samples, cross-validation, amplitude t-ratio,
// physical bounds), repeat until nothing passes; report near-ties as
// ambiguous; finally try generic probes, which flag structure that none of
// the library's effects explains.
//
// Evidence. Tables (independent errors): the F-test of the nested models.
// Series: the noise is white plus a Gauss-Markov wander fitted to each
// model's residual (wander_noise.hpp); the statistic is the likelihood ratio
// of the generalised least squares fits against chi-square, divided by the
// Newey-West long-run variance factor of the effect's amplitude: of the
// product of its (whitened, other columns partialled out) regressor and the
// whitened residual, with a bandwidth longer than the wander's correlation.
// The fitted wander understates slow wander the flexible bias curve soaked
// up; what is left shows there, and a slow candidate (a drift, a warm-up)
// is judged against it rather than against white noise.
namespace gyrotc::identify {

struct EffectReadout {
  std::vector<EffectParam> params;  // in the units of the effect library
  double t_ratio = 0.0;             // |amplitude| / standard error
  bool in_bounds = false;           // every parameter physically plausible
  // Index of the amplitude in [beta; theta] (series: its long-run variance
  // is checked; -1 = none), and of a second one whose factor counts too
  // (a periodic term's sine and cosine).
  Eigen::Index amplitude_index = -1;
  Eigen::Index second_amplitude_index = -1;
};

// Where a scanned probe starts: its theta at the alternatives a scan of the
// current model's residual found best, and how many alternatives the scan
// looked at (the probe's p-value is multiplied by that: it is the best of
// many).
struct ProbeScan {
  std::vector<std::vector<double>> starts;
  double alternatives = 1.0;
};

struct SelectionProblem {
  Eigen::VectorXd y;
  std::vector<std::string> candidates;  // library order
  // Generic alternatives (e.g. a spline in time) tried after the library:
  // one that passes means structure remains that no library effect explains.
  // Never added to the model.
  std::vector<std::string> probes;
  // Probes with a few parameters a scan finds (a level change's time, a
  // period): no catch-all, so they are tested as library effects are (each
  // model with its own wander, the amplitude's long-run variance and
  // t-ratio; `readout` is called for them), from the starts the scan of the
  // current model's least-squares residual and design gives. No starts: an
  // ordinary probe. May be empty.
  std::function<ProbeScan(const std::string& probe, const Eigen::VectorXd& residual, const Eigen::MatrixXd& design)>
      scan;
  // The model with these effects (and probes) switched on (empty = baseline).
  std::function<SeparableModel(const std::vector<std::string>& effects)> build;
  // Parameters of `effect` in a fit of the model with `effects`; covariance
  // is the scaled covariance of [beta; theta]. Not called for probes.
  std::function<EffectReadout(const std::string& effect, const std::vector<std::string>& effects,
                              const SeparableFit& fit, const Eigen::MatrixXd& covariance)>
      readout;
  // Cross-validation: fold of each sample (0..folds-1).
  std::vector<int> fold_of;
  int folds = 5;
  // Held-out units for comparing two candidates (CV blocks of a series, the
  // points of a table): index of each sample's unit; empty = fold_of.
  std::vector<int> unit_of;
  // Optional (long records): a held-out sample counts only if its leverage
  // in the baseline fitted to the training folds stays at or below this (0 =
  // no limit), so no fold is scored on extrapolating the bias curve to
  // temperatures only it visits. The same samples are scored for every model.
  double max_held_out_leverage = 0.0;
  // Static tables (few points): refit theta on each fold; long records keep
  // theta at its full-data value and refit the linear part only.
  bool refit_theta_in_cv = false;
  // Long records: the time of each sample (any spacing). Non-empty switches
  // the noise model to white + wander and the evidence to the GLS likelihood.
  std::vector<double> time_s;
  std::vector<double> white_scale;  // relative white variance per sample (empty = 1)
  double wander_tau_min_s = 1.0;
  double wander_tau_max_s = 1e4;
  // Candidates the record cannot tell apart (e.g. rate_sensitivity and
  // ambient_sensitivity when the casing follows the ambient as a first-order
  // lag): when the best is in a group, the others of the group that pass make
  // the verdict ambiguous whatever their scores.
  std::vector<std::vector<std::string>> confounded;
};

struct SelectionResult {
  std::vector<AddedEffect> added;
  std::vector<CandidateScore> tried;
  std::string verdict;
  std::vector<std::string> ambiguous;    // the tied candidates, when ambiguous
  std::vector<std::string> unexplained;  // probes that passed
  std::vector<Alternative> alternatives; // without the experiment (the record's to say)
  SeparableFit baseline;
  SeparableFit final_fit;
  WanderNoise baseline_noise;  // series only
  WanderNoise final_noise;
};

// progress(fraction) is called as candidates are tried (may be empty).
SelectionResult select_effects(const SelectionProblem& problem, const Criteria& criteria,
                               const std::function<void(double)>& progress = {});

// The verdict in words ("consistent with thermal_lag", ...): what the
// statistics support, not a claim that the effect is the cause.
std::string verdict_statement(const SelectionResult& result);

}  // namespace gyrotc::identify
