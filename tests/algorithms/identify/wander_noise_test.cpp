#include <cmath>
#include <random>
#include <span>
#include <vector>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc/algorithms/identify/wander_noise.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::identify;

namespace {

// White noise (sd white_sd) plus a first-order Gauss-Markov wander (sd
// wander_sd, correlation time tau_s), exact discretisation, at times t.
Eigen::VectorXd noise_at(const std::vector<double>& t, double white_sd, double wander_sd, double tau_s,
                         std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd out(static_cast<Eigen::Index>(t.size()));
  double wander = wander_sd * normal(rng);
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (i > 0) {
      const double phi = std::exp(-(t[i] - t[i - 1]) / tau_s);
      wander = phi * wander + wander_sd * std::sqrt(1.0 - phi * phi) * normal(rng);
    }
    out(static_cast<Eigen::Index>(i)) = wander + white_sd * normal(rng);
  }
  return out;
}

double lag_correlation(const Eigen::VectorXd& v, Eigen::Index lag) {
  const Eigen::VectorXd c = v.array() - v.mean();
  return c.head(c.size() - lag).dot(c.tail(c.size() - lag)) / c.squaredNorm();
}

}  // namespace

TEST_CASE("the maximum-likelihood wander fit recovers the variance and correlation time of the bias wander") {
  std::vector<double> t;
  for (int i = 0; i < 20000; ++i) t.push_back(8.0 * i);
  const Eigen::VectorXd e = noise_at(t, 0.08, 0.15, 400.0, 3);
  const WanderNoise fitted = fit_wander_noise(e, t, {}, 8.0, 40000.0);
  CHECK(std::sqrt(fitted.white_var) == Approx(0.08).epsilon(0.1));
  CHECK(std::sqrt(fitted.wander_var) == Approx(0.15).epsilon(0.15));
  CHECK(fitted.tau_s == Approx(400.0).epsilon(0.3));
}

TEST_CASE("white noise alone is fitted with no wander to speak of") {
  std::vector<double> t;
  for (int i = 0; i < 5000; ++i) t.push_back(i);
  const Eigen::VectorXd e = noise_at(t, 1.0, 0.0, 10.0, 4);
  const WanderNoise fitted = fit_wander_noise(e, t, {}, 1.0, 1000.0);
  CHECK(fitted.wander_var < 0.01 * fitted.white_var);
}

TEST_CASE("the innovations of white noise plus slow wander are white, so held-out blocks are independent") {
  std::vector<double> t;
  for (int i = 0; i < 6000; ++i) t.push_back(4.0 * i);
  Eigen::VectorXd e = noise_at(t, 0.07, 0.15, 1000.0, 5);
  // The raw series is strongly correlated far beyond a 300 s block...
  CHECK(lag_correlation(e, 75) > 0.5);
  const Whitener w(WanderNoise{0.07 * 0.07, 0.15 * 0.15, 1000.0}, t);
  w.apply(e);
  // ... its innovations are not, and have the white variance.
  for (Eigen::Index lag : {1, 2, 5, 75}) {
    INFO("lag " << lag);
    CHECK(std::fabs(lag_correlation(e, lag)) < 0.05);
  }
  CHECK(long_run_variance_factor({e.data(), static_cast<std::size_t>(e.size())}) < 1.2);
  CHECK(e.squaredNorm() / static_cast<double>(e.size()) == Approx(0.07 * 0.07).epsilon(0.1));
}

TEST_CASE("across a gap the wander has decorrelated: the filter uses the actual time step") {
  // Two halves 20 correlation times apart: whitened as one series with the
  // gap, the first sample after it is predicted from nothing (innovation
  // variance back to wander + white), not from the sample before the gap.
  std::vector<double> t;
  for (int i = 0; i < 400; ++i) t.push_back(i);
  for (int i = 0; i < 400; ++i) t.push_back(2400.0 + i);
  const WanderNoise noise{0.01, 1.0, 100.0};
  Eigen::VectorXd step = Eigen::VectorXd::Zero(800);
  step.tail(400).setConstant(1.0);  // a level shift across the gap
  const Whitener w(noise, t);
  w.apply(step);
  // In units of the white sd (0.1): the shift over the stationary sd of
  // wander + white, sqrt(1.01). Had the filter taken the 1 s step of the
  // other samples, the innovation variance would be its steady state (about
  // 3.7 white variances) and the value about 0.52.
  CHECK(step(400) == Approx(1.0 / std::sqrt(101.0)).epsilon(1e-3));
}
