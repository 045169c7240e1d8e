#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/chi_square.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::stats;

namespace {

// The averages over every run of m consecutive samples.
std::vector<double> cluster_averages(const std::vector<double>& y, std::size_t m) {
  std::vector<double> avg(y.size() - m + 1);
  for (std::size_t k = 0; k + m <= y.size(); ++k) {
    double s = 0.0;
    for (std::size_t j = 0; j < m; ++j) s += y[k + j];
    avg[k] = s / static_cast<double>(m);
  }
  return avg;
}

// Reference: overlapping Allan variance straight from its definition, O(n*m):
// the mean of every run of m samples, then half the mean squared difference
// of runs m apart.
double direct_avar(const std::vector<double>& y, std::size_t m) {
  const std::vector<double> avg = cluster_averages(y, m);
  double sum = 0.0;
  std::size_t terms = 0;
  for (std::size_t k = 0; k + m < avg.size(); ++k) {
    const double d = avg[k + m] - avg[k];
    sum += d * d;
    ++terms;
  }
  return sum / (2.0 * static_cast<double>(terms));
}

// The Hadamard variance from its definition on cluster averages: the second
// difference of three consecutive averages, squared, over 6.
double direct_hvar(const std::vector<double>& y, std::size_t m) {
  const std::vector<double> avg = cluster_averages(y, m);
  double sum = 0.0;
  std::size_t terms = 0;
  for (std::size_t k = 0; k + 2 * m < avg.size(); ++k) {
    const double d = avg[k + 2 * m] - 2.0 * avg[k + m] + avg[k];
    sum += d * d;
    ++terms;
  }
  return sum / (6.0 * static_cast<double>(terms));
}

// White rate noise of density n_true (units*sqrt(s)) plus a rate random walk
// of density k_true (units/sqrt(s)) at rate_hz.
std::vector<double> synthetic(std::size_t n, double rate_hz, double n_true, double k_true, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const double tau0 = 1.0 / rate_hz;
  const double white_sigma = n_true / std::sqrt(tau0);
  const double walk_step = k_true * std::sqrt(tau0);
  std::vector<double> y(n);
  double walk = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    walk += walk_step * g(rng);
    y[i] = 0.7 + walk + white_sigma * g(rng);
  }
  return y;
}

}  // namespace

TEST_CASE("overlapping Allan deviation from cumulative sums matches the O(n*m) definition to 1e-12") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> y(501);
  double walk = 0.0;
  for (auto& v : y) {
    walk += 0.05 * g(rng);
    v = 3.0 + walk + g(rng);
  }
  const AllanResult r = allan_deviation(y, 50.0);
  REQUIRE(r.points.size() > 10);
  CHECK(r.points.back().m == 250);
  for (const auto& p : r.points) {
    const double ref = std::sqrt(direct_avar(y, p.m));
    INFO("m = " << p.m);
    CHECK(std::fabs(p.adev - ref) <= 1e-12 * ref);
    CHECK(p.tau_s == Approx(static_cast<double>(p.m) / 50.0));
  }
}

TEST_CASE("overlapping Hadamard deviation from cumulative sums matches its definition to 1e-12, where 3 m <= n") {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> y(501);
  double walk = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    walk += 0.05 * g(rng);
    y[i] = 3.0 + 0.01 * static_cast<double>(i) + walk + g(rng);
  }
  const AllanResult r = allan_deviation(y, 50.0);
  for (const auto& p : r.points) {
    INFO("m = " << p.m);
    if (3 * p.m > y.size()) {
      CHECK(p.hdev == 0.0);
      continue;
    }
    const double ref = std::sqrt(direct_hvar(y, p.m));
    CHECK(std::fabs(p.hdev - ref) <= 1e-12 * ref);
  }
}

TEST_CASE("cluster sizes are log-spaced, finer than octaves, from 1 to n/2") {
  const auto sizes = allan_cluster_sizes(100000, 10.0);
  REQUIRE(sizes.front() == 1);
  CHECK(sizes.back() <= 50000);
  CHECK(sizes.back() > 25000);
  for (std::size_t i = 1; i < sizes.size(); ++i) {
    CHECK(sizes[i] > sizes[i - 1]);
    CHECK(static_cast<double>(sizes[i]) <= 2.0 * static_cast<double>(sizes[i - 1]));
  }
}

TEST_CASE("white noise: the angle random walk is recovered within 5 % and no other term is reported") {
  const double n_true = 0.01;  // deg/sqrt(s)
  for (unsigned seed : {1u, 2u}) {
    const auto y = synthetic(60000, 100.0, n_true, 0.0, seed);
    const AllanResult r = allan_deviation(y, 100.0);
    REQUIRE(r.fit.valid);
    const TermEstimate& n = r.fit.term(NoiseTerm::angle_random_walk);
    INFO("seed " << seed << ": N = " << n.value);
    REQUIRE(n.included);
    CHECK(std::fabs(n.value - n_true) <= 0.05 * n_true);
    CHECK(n.ci_low <= n_true);
    CHECK(n_true <= n.ci_high);
    for (NoiseTerm t : {NoiseTerm::bias_instability, NoiseTerm::rate_random_walk, NoiseTerm::rate_ramp}) {
      INFO(noise_term_name(t));
      CHECK_FALSE(r.fit.term(t).included);
    }
  }
}

TEST_CASE("each point's interval is the chi-square interval of its EDF and narrows with more clusters") {
  const auto y = synthetic(10000, 10.0, 0.01, 0.0, 5);
  const AllanResult r = allan_deviation(y, 10.0);
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    const auto& p = r.points[i];
    INFO("m = " << p.m);
    CHECK(p.ci_low <= p.adev);
    CHECK(p.ci_high >= p.adev);
    CHECK(p.ci_high * p.ci_high == Approx(p.adev * p.adev * p.edf / chi_square_quantile(0.025, p.edf)).epsilon(1e-9));
    if (i > 0) CHECK(p.ci_high / p.adev > r.points[i - 1].ci_high / r.points[i - 1].adev);
  }
}

TEST_CASE("bad records are rejected") {
  const std::vector<double> one{1.0};
  CHECK_THROWS_AS(allan_deviation(one, 10.0), std::invalid_argument);
  const std::vector<double> with_nan{1.0, std::nan(""), 2.0};
  CHECK_THROWS_AS(allan_deviation(with_nan, 10.0), std::invalid_argument);
  const std::vector<double> two{1.0, 2.0};
  CHECK_THROWS_AS(allan_deviation(two, 0.0), std::invalid_argument);
  CHECK(allan_deviation(two, 1.0).points.size() == 1);
}

TEST_CASE("fit options outside their range are rejected") {
  const std::vector<double> y(100, 1.0);
  AllanOptions o;
  o.discrepancy_correlation = 1.5;  // the discrepancy's covariance would not be positive
  CHECK_THROWS_AS(allan_deviation(y, 10.0, o), std::invalid_argument);
  o = {};
  o.hadamard_decades = -1.0;
  CHECK_THROWS_AS(allan_deviation(y, 10.0, o), std::invalid_argument);
  o = {};
  o.walk_blocks = 5;  // too few block means for a covariance
  CHECK_THROWS_AS(allan_deviation(y, 10.0, o), std::invalid_argument);
  o.walk_blocks = 0;  // off
  CHECK_NOTHROW(allan_deviation(y, 10.0, o));
}

TEST_CASE("a 10^7-sample record is handled") {
  const auto y = synthetic(10000000, 1000.0, 0.005, 0.0, 21);
  const auto start = std::chrono::steady_clock::now();
  const AllanResult r = allan_deviation(y, 1000.0);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WARN("allan_deviation on 1e7 samples: " << r.points.size() << " cluster times in " << wall_s << " s");
  REQUIRE(r.points.size() > 60);
  CHECK(r.fit.term(NoiseTerm::angle_random_walk).value == Approx(0.005).epsilon(0.05));
}
