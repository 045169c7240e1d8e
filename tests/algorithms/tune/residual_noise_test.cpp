// The noise under a least-squares residual, and the covariance it implies,
// on a linear fit whose truth is known: a level, a trend and a slow wave
// fitted to a record with white noise and a first-order noise of 100 rows
// (and, below, with noise on two time scales).
#include "gyrotc/algorithms/tune/residual_noise.hpp"

#include <cmath>
#include <cstdint>
#include <random>

#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

constexpr int kRows = 3000;
constexpr double kWhiteSd = 0.02;
constexpr double kSlowSd = 0.03;
constexpr double kSlowTauRows = 100.0;

Eigen::MatrixXd design() {
  Eigen::MatrixXd j(kRows, 3);
  for (int t = 0; t < kRows; ++t) {
    j(t, 0) = 1.0;
    j(t, 1) = t / static_cast<double>(kRows);
    j(t, 2) = std::sin(2.0 * M_PI * t / 1500.0);  // slow: the fit takes some of the slow noise
  }
  return j;
}

Eigen::VectorXd noise(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  const double phi = std::exp(-1.0 / kSlowTauRows);
  Eigen::VectorXd e(kRows);
  double slow = kSlowSd * normal(rng);
  for (int t = 0; t < kRows; ++t) {
    slow = phi * slow + kSlowSd * std::sqrt(1.0 - phi * phi) * normal(rng);
    e(t) = slow + kWhiteSd * normal(rng);
  }
  return e;
}

struct Fit {
  Eigen::VectorXd beta;
  Eigen::VectorXd residual;
};

Fit least_squares(const Eigen::MatrixXd& j, const Eigen::VectorXd& y) {
  const Eigen::VectorXd beta = j.colPivHouseholderQr().solve(y);
  return {beta, y - j * beta};
}

// The wave coefficient's scatter over records of the generator's noise (its
// truth is 0) and the mean standard error the fitted noise gives it.
struct Scatter {
  double scatter_sd = 0.0;
  double mean_se = 0.0;
};

Scatter wave_scatter(Eigen::VectorXd (*generate)(std::mt19937_64&), tune::NoiseParts parts, std::uint64_t seed) {
  const Eigen::MatrixXd j = design();
  const Eigen::MatrixXd inverse_normal = (j.transpose() * j).inverse();
  std::mt19937_64 rng(seed);
  constexpr int kRecords = 300;
  double scatter = 0.0, mean_var = 0.0;
  for (int r = 0; r < kRecords; ++r) {
    const Fit f = least_squares(j, generate(rng));
    scatter += f.beta(2) * f.beta(2) / kRecords;
    const tune::ResidualNoise noise_fit = tune::fit_residual_noise(j, f.residual, parts);
    mean_var += tune::noise_covariance(j, inverse_normal, noise_fit)(2, 2) / kRecords;
  }
  return {std::sqrt(scatter), std::sqrt(mean_var)};
}

}  // namespace

TEST_CASE("the noise fitted to a residual recovers the white and the slow part of the record's noise") {
  const Eigen::MatrixXd j = design();
  std::mt19937_64 rng(11);
  double slow_sd = 0.0, white_sd = 0.0, log_tau = 0.0;
  constexpr int kRecords = 20;
  for (int r = 0; r < kRecords; ++r) {
    const tune::ResidualNoise n = tune::fit_residual_noise(j, least_squares(j, noise(rng)).residual);
    slow_sd += std::sqrt(n.slow_var) / kRecords;
    white_sd += std::sqrt(n.white_var) / kRecords;
    log_tau += std::log(n.slow_tau_rows) / kRecords;
  }
  CHECK(slow_sd == Approx(kSlowSd).epsilon(0.15));
  CHECK(white_sd == Approx(kWhiteSd).epsilon(0.1));
  CHECK(std::exp(log_tau) == Approx(kSlowTauRows).epsilon(0.3));
}

TEST_CASE("the standard error of a slow regressor's coefficient is its scatter over records", "[sweep]") {
  // Without the fit's projection accounted for, the slow noise the wave's
  // coefficient takes in is missing from the residual and the error is low.
  const Scatter one = wave_scatter(noise, tune::NoiseParts::one, 12);
  INFO("scatter sd " << one.scatter_sd << ", mean standard error " << one.mean_se);
  CHECK(one.mean_se == Approx(one.scatter_sd).epsilon(0.12));
}

TEST_CASE("the covariance stays positive when the parameters' scales differ by orders of magnitude") {
  // Scales 1e-6..1e6 and two columns alike to 1e-9, as a fit's parameters
  // on a record that cannot tell them apart: formed as inv J'CJ inv, the
  // diagonal came out negative.
  Eigen::MatrixXd j(kRows, 4);
  j.leftCols(3) = design();
  for (int t = 0; t < kRows; ++t) j(t, 3) = 1.0 + 1e-9 * std::cos(2.0 * M_PI * t / 700.0);
  j.col(1) *= 1e6;
  j.col(2) *= 1e-6;
  j.col(3) *= 1e3;
  const Eigen::MatrixXd inverse_normal = (j.transpose() * j).inverse();
  const Eigen::MatrixXd c = tune::noise_covariance(j, inverse_normal, {1e-4, 0.6, 2000.0});
  for (Eigen::Index i = 0; i < c.rows(); ++i) CHECK(c(i, i) > 0.0);
}

namespace {

// Noise on two time scales: white, a fast first-order part (a sensor's own)
// and a slow one (a DS18B20 step held while the casing sits still).
constexpr double kFastSd = 0.03;
constexpr double kFastTauRows = 5.0;
constexpr double kSlowerSd = 0.02;
constexpr double kSlowerTauRows = 300.0;

Eigen::VectorXd two_scale_noise(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  const double phi_fast = std::exp(-1.0 / kFastTauRows);
  const double phi_slow = std::exp(-1.0 / kSlowerTauRows);
  Eigen::VectorXd e(kRows);
  double fast = kFastSd * normal(rng);
  double slow = kSlowerSd * normal(rng);
  for (int t = 0; t < kRows; ++t) {
    fast = phi_fast * fast + kFastSd * std::sqrt(1.0 - phi_fast * phi_fast) * normal(rng);
    slow = phi_slow * slow + kSlowerSd * std::sqrt(1.0 - phi_slow * phi_slow) * normal(rng);
    e(t) = fast + slow + kWhiteSd * normal(rng);
  }
  return e;
}

}  // namespace

TEST_CASE("with noise on two time scales, one first-order part leaves a slow coefficient's standard error at half its scatter", "[sweep]") {
  // Why tune fits two parts (thermal_identify.cpp): measured 0.55x.
  const Scatter one = wave_scatter(two_scale_noise, tune::NoiseParts::one, 13);
  INFO("scatter sd " << one.scatter_sd << ", mean standard error " << one.mean_se);
  CHECK(one.mean_se < 0.7 * one.scatter_sd);
}

TEST_CASE("with noise on two time scales, two first-order parts give a slow coefficient's standard error near its scatter", "[sweep]") {
  // Measured 0.87x: the slower part's time constant is read from one
  // 3000-row record whose wave takes in some of it (fitted 90..2500 rows
  // for a truth of 300).
  const Scatter two = wave_scatter(two_scale_noise, tune::NoiseParts::two, 13);
  INFO("scatter sd " << two.scatter_sd << ", mean standard error " << two.mean_se);
  CHECK(two.mean_se == Approx(two.scatter_sd).epsilon(0.2));
}
