#pragma once

#include <Eigen/Dense>

#include <span>
#include <vector>

// The noise of a long gyro record: white noise plus a slow Gauss-Markov
// wander of the bias (first-order, correlation time tau_s), on samples at
// arbitrary times. Part of the baseline model of `gyrotc identify`: the
// wander is fitted to each model's residual by maximum likelihood, so slow
// wander is noise with its own spectrum, not structure an effect can claim.
//
// The Kalman filter of that noise turns a series into its one-step
// prediction errors (innovations) scaled to the white variance: independent
// when the noise model holds. Regressing the filtered data on the filtered
// design is generalised least squares; its likelihood is the evidence.
namespace gyrotc::identify {

struct WanderNoise {
  double white_var = 1.0;   // variance of the white part at white_scale 1
  double wander_var = 0.0;  // stationary variance of the wander
  double tau_s = 1.0;       // its correlation time
};

class Whitener {
 public:
  // white_scale: relative white variance of each sample (1/samples averaged
  // in a bin); empty = 1 for all. time_s increasing.
  Whitener(const WanderNoise& noise, std::span<const double> time_s,
           std::span<const double> white_scale = {});

  // Replaces each column by its scaled innovations, in place. Entries below
  // 1e-12 of their column's largest are set to zero, so a sparse column (a
  // spline basis function) stays sparse past its support instead of
  // carrying a decaying tail (gram_matrix skips zeros).
  void apply(Eigen::Ref<Eigen::MatrixXd> columns) const;
  // Sum of ln of the innovation variances in units of white_var.
  double log_det() const noexcept { return log_det_; }
  std::size_t size() const noexcept { return gain_.size(); }

 private:
  std::vector<double> decay_;      // wander decay from the previous sample
  std::vector<double> gain_;       // Kalman gain
  std::vector<double> inv_sd_;     // 1 / sqrt(innovation variance / white_var)
  double log_det_ = 0.0;
};

// Generalised least squares of data on design under a noise model (its
// wander-to-white ratio and tau; the white variance is estimated).
struct GlsFit {
  Eigen::VectorXd beta;
  Eigen::VectorXd white_residual;  // innovations of data - design * beta, scaled to the white sd
  double white_var = 1.0;          // white variance, sum of squares / (n - columns)
  double log_likelihood = 0.0;     // Gaussian, white variance concentrated out, up to a constant
};

GlsFit fit_gls(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
               std::span<const double> time_s, std::span<const double> white_scale = {});

// Maximum-likelihood wander + white noise of a residual: tau searched within
// [tau_min_s, tau_max_s] from a coarse grid (and `start` when given), a zero
// wander a candidate. White noise alone when there are fewer than 8 samples.
WanderNoise fit_wander_noise(const Eigen::VectorXd& residual, std::span<const double> time_s,
                             std::span<const double> white_scale, double tau_min_s, double tau_max_s,
                             const WanderNoise* start = nullptr);

// The restricted (REML) log-likelihood of data under design and noise, the
// white variance concentrated out, up to a constant: the likelihood of the
// residual's n - p contrasts, which does not count the design's fitted
// coefficients as known (-1/2 ln det of the whitened normal matrix); and
// the full likelihood, as fit_gls gives it.
struct NoiseLikelihoods {
  double restricted = 0.0;
  double full = 0.0;
};
NoiseLikelihoods noise_likelihoods(const Eigen::VectorXd& data, const Eigen::MatrixXd& design, const WanderNoise& noise,
                                   std::span<const double> time_s, std::span<const double> white_scale = {});
// The wander's ratio to the white variance and its tau, moved from `start`
// (a maximum-likelihood fit) towards the restricted likelihood's optimum by a
// shrinking pattern search, within the full likelihood's 95 % region about
// the start; white_var of the result is 1 (a ratio). A start without wander
// is returned as it is.
WanderNoise refine_wander_noise_restricted(const Eigen::VectorXd& data, const Eigen::MatrixXd& design,
                                           std::span<const double> time_s, std::span<const double> white_scale,
                                           double tau_min_s, double tau_max_s, const WanderNoise& start);

}  // namespace gyrotc::identify
