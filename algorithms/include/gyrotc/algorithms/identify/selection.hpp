#pragma once

#include <Eigen/Dense>

#include <functional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/identification.hpp"
#include "gyrotc/algorithms/identify/separable_fit.hpp"

// The target-independent core of step 3 of the workflow: try each named
// effect on top of the current model, refit everything jointly, keep the best
// that passes every test (BIC with an effective sample size, blocked
// cross-validation, amplitude t-ratio, physical bounds), repeat until nothing
// passes; report near-ties as ambiguous.
namespace gyrotc::identify {

struct EffectReadout {
  std::vector<EffectParam> params;  // in the units of the effect library
  double t_ratio = 0.0;             // |amplitude| / standard error
  bool in_bounds = false;           // every parameter physically plausible
};

struct SelectionProblem {
  Eigen::VectorXd y;
  std::vector<std::string> candidates;  // library order
  // The model with these effects switched on (empty = baseline).
  std::function<SeparableModel(const std::vector<std::string>& effects)> build;
  // Parameters of `effect` in a fit of the model with `effects`; covariance
  // is the scaled covariance of [beta; theta].
  std::function<EffectReadout(const std::string& effect, const std::vector<std::string>& effects,
                              const SeparableFit& fit, const Eigen::MatrixXd& covariance)>
      readout;
  // Cross-validation: fold of each sample (0..folds-1).
  std::vector<int> fold_of;
  int folds = 5;
  // Optional (long records): the temperature of each sample. A held-out
  // sample counts only if the training folds hold samples within the same
  // coverage_cell of it, so no fold is scored on extrapolating the bias curve
  // to temperatures only it visits.
  std::vector<double> coverage_key;
  double coverage_cell = 1.0;
  // Static tables (few points): refit theta on each fold; long records keep
  // theta at its full-data value and refit the linear part only.
  bool refit_theta_in_cv = false;
  // Long records: BIC and standard errors use the AR(1) effective size.
  bool autocorrelated = true;
};

struct SelectionResult {
  std::vector<AddedEffect> added;
  std::vector<CandidateScore> tried;
  std::string verdict;
  std::vector<std::string> ambiguous;  // the tied candidates, when ambiguous
  SeparableFit baseline;
  SeparableFit final_fit;
};

// progress(fraction) is called as candidates are tried (may be empty).
SelectionResult select_effects(const SelectionProblem& problem, const Criteria& criteria,
                               const std::function<void(double)>& progress = {});

}  // namespace gyrotc::identify
