// The pieces of `gyrotc allan`'s noise fit: chi-square quantiles, the EDF
// and covariance of the overlapping estimator, the synthetic records of
// known noise, and the fit on them (a small subset of tools/allan_study).
#include <cmath>
#include <vector>

#include "gyrotc/algorithms/model/rate_noise.hpp"
#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/allan_covariance.hpp"
#include "gyrotc/algorithms/stats/allan_edf.hpp"
#include "gyrotc/algorithms/stats/chi_square.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::stats;
using gyrotc::model::RateNoise;
using gyrotc::model::generate_rate_noise;

namespace {

// Overlapping Allan (differences 2) or Hadamard (differences 3) variance at
// cluster size m, straight from the angle: the mean square of the angle's
// finite differences (binomial weights) over 2 or 6 tau^2.
double variance_at(const std::vector<double>& y, std::size_t m, int differences) {
  std::vector<double> theta(y.size() + 1, 0.0);
  for (std::size_t i = 0; i < y.size(); ++i) theta[i + 1] = theta[i] + y[i];
  const std::vector<double> w = differences == 2 ? std::vector<double>{1.0, -2.0, 1.0} : std::vector<double>{-1.0, 3.0, -3.0, 1.0};
  const std::size_t terms = theta.size() - static_cast<std::size_t>(differences) * m;
  double sum = 0.0;
  for (std::size_t k = 0; k < terms; ++k) {
    double d = 0.0;
    for (std::size_t j = 0; j < w.size(); ++j) d += w[j] * theta[k + j * m];
    sum += d * d;
  }
  return sum / ((differences == 2 ? 2.0 : 6.0) * static_cast<double>(m * m) * static_cast<double>(terms));
}

double avar_at(const std::vector<double>& y, std::size_t m) { return variance_at(y, m, 2); }
double hvar_at(const std::vector<double>& y, std::size_t m) { return variance_at(y, m, 3); }

// The sample covariance of two series of estimates over the same runs.
double sample_covariance(const std::vector<double>& x, const std::vector<double>& y) {
  const auto runs = static_cast<double>(x.size());
  double mx = 0.0;
  double my = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    mx += x[k] / runs;
    my += y[k] / runs;
  }
  double s = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) s += (x[k] - mx) * (y[k] - my);
  return s / (runs - 1.0);
}

constexpr PowerLawNoise kTypes[] = {PowerLawNoise::quantisation, PowerLawNoise::white_rate,
                                    PowerLawNoise::flicker_rate, PowerLawNoise::random_walk_rate};

}  // namespace

TEST_CASE("chi-square quantiles match the printed tables") {
  // Abramowitz & Stegun Table 26.8.
  CHECK(chi_square_quantile(0.025, 1.0) == Approx(0.000982069).epsilon(1e-5));
  CHECK(chi_square_quantile(0.975, 1.0) == Approx(5.02389).epsilon(1e-5));
  CHECK(chi_square_quantile(0.025, 10.0) == Approx(3.24697).epsilon(1e-5));
  CHECK(chi_square_quantile(0.975, 10.0) == Approx(20.4832).epsilon(1e-5));
  CHECK(chi_square_quantile(0.95, 100.0) == Approx(124.342).epsilon(1e-5));
  CHECK(chi_square_cdf(2.0, 2.0) == Approx(1.0 - std::exp(-1.0)));
}

TEST_CASE("Greenhall's EDF agrees with the Howe-Allan-Barnes approximations, and is exact for white noise") {
  for (PowerLawNoise t : kTypes) {
    for (std::size_t m : {4u, 10u, 50u, 300u, 2000u}) {
      INFO("type " << static_cast<int>(t) << ", m " << m);
      CHECK(overlapping_avar_edf(t, m, 20000) == Approx(overlapping_avar_edf_simple(t, m, 20000)).epsilon(0.1));
    }
  }
  // White rate noise at m = 1: M = n - 1 squared first differences of the
  // rate, neighbours with correlation 1/4 (M - 1 pairs): nu = 2 M^2 / (3M - 1).
  CHECK(overlapping_avar_edf(PowerLawNoise::white_rate, 1, 30000) == Approx(2.0 * 29999.0 * 29999.0 / (3.0 * 29999.0 - 1.0)).epsilon(1e-9));
}

TEST_CASE("the covariance's diagonal gives Greenhall's EDF for every noise type") {
  const std::size_t n = 50000;
  const double tau0 = 0.01;
  const std::vector<std::size_t> m = allan_cluster_sizes(n, 5.0);
  const AvarCovariance cov(m, n, tau0);
  const int powers[] = {-2, -1, 0, 1};
  for (int j = 0; j < 4; ++j) {
    std::array<double, 4> c{};
    c[static_cast<std::size_t>(j)] = 1.0;
    const Eigen::MatrixXd s = cov.covariance(c);
    for (std::size_t i = 0; i < m.size(); ++i) {
      const double avar = std::pow(static_cast<double>(m[i]) * tau0, powers[j]);
      const double edf = 2.0 * avar * avar / s(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i));
      INFO("type " << j << ", m " << m[i]);
      CHECK(edf == Approx(overlapping_avar_edf(kTypes[j], m[i], n)).epsilon(0.01));
    }
  }
}

TEST_CASE("the modelled covariance of the estimates matches a simulation of white noise and a random walk") {
  const std::size_t n = 2000;
  const double rate_hz = 10.0;
  const RateNoise noise{0.0, 0.02, 0.0, 2e-3, 0.0};
  const std::vector<std::size_t> m{2, 3, 5, 8, 50, 80, 200};
  const int runs = 400;
  std::vector<std::vector<double>> a(m.size());
  for (int s = 1; s <= runs; ++s) {
    const std::vector<double> y = generate_rate_noise(noise, rate_hz, n, static_cast<std::uint64_t>(s));
    for (std::size_t i = 0; i < m.size(); ++i) a[i].push_back(avar_at(y, m[i]));
  }
  const AvarCovariance cov(m, n, 1.0 / rate_hz);
  const Eigen::MatrixXd model = cov.covariance({0.0, noise.arw * noise.arw, 0.0, noise.rrw * noise.rrw / 3.0});
  auto covariance = [&](std::size_t i, std::size_t j) { return sample_covariance(a[i], a[j]); };
  for (std::size_t i = 0; i < m.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    INFO("m " << m[i]);
    // 400 runs: the variance is known to about 7 % (one sigma).
    CHECK(covariance(i, i) / model(ii, ii) == Approx(1.0).margin(0.25));
    // Neighbours within a factor 3 correlate 0.3-0.8, known to about 0.03 from 400 runs.
    if (i + 1 < m.size() && m[i + 1] <= 3 * m[i]) {
      const auto jj = ii + 1;
      const double simulated = covariance(i, i + 1) / std::sqrt(covariance(i, i) * covariance(i + 1, i + 1));
      CHECK(simulated == Approx(model(ii, jj) / std::sqrt(model(ii, ii) * model(jj, jj))).margin(0.08));
    }
  }
}

TEST_CASE("the Allan estimate's expected value is tau^p per unit coefficient, the Hadamard's white rate 1, random walk 1/2, white angle 10/9") {
  const double tau0 = 0.1;
  const std::vector<VarianceEstimate> e{{40, 2}, {40, 3}};
  const AvarCovariance cov(e, 20000, tau0);
  const double tau = 40 * tau0;
  const int powers[] = {-2, -1, 0, 1};
  for (int j = 0; j < 4; ++j) {
    INFO("type " << j);
    CHECK(cov.expected(0, j) == Approx(std::pow(tau, powers[j])).epsilon(1e-12));
  }
  CHECK(cov.expected(1, 0) == Approx(10.0 / 9.0 / (tau * tau)).epsilon(1e-12));
  CHECK(cov.expected(1, 1) == Approx(1.0 / tau).epsilon(1e-12));
  CHECK(cov.expected(1, 3) == Approx(0.5 * tau).epsilon(1e-12));
}

TEST_CASE("synthetic records have the Hadamard variance the covariance model expects, flicker included") {
  const double rate_hz = 10.0;
  const std::size_t n = 20000;
  const std::size_t m = 40;
  const VarianceEstimate h{m, 3};
  const AvarCovariance cov(std::span<const VarianceEstimate>(&h, 1), n, 1.0 / rate_hz);
  const RateNoise cases[] = {{0.005, 0.0, 0.0, 0.0, 0.0}, {0.0, 0.02, 0.0, 0.0, 0.0}, {0.0, 0.0, 1e-3, 0.0, 0.0},
                             {0.0, 0.0, 0.0, 1e-3, 0.0}};
  const NoiseTerm terms[] = {NoiseTerm::quantisation, NoiseTerm::angle_random_walk, NoiseTerm::bias_instability,
                             NoiseTerm::rate_random_walk};
  const double values[] = {0.005, 0.02, 1e-3, 1e-3};
  for (int j = 0; j < 4; ++j) {
    INFO(noise_term_name(terms[j]));
    double mean = 0.0;
    for (std::uint64_t s = 1; s <= 10; ++s) mean += hvar_at(generate_rate_noise(cases[j], rate_hz, n, s), m) / 10.0;
    CHECK(mean == Approx(avar_coefficient(terms[j], values[j]) * cov.expected(0, j)).epsilon(0.05));
  }
  // A ramp: no Hadamard variance at all (third differences of a parabola).
  CHECK(hvar_at(generate_rate_noise({0.0, 0.0, 0.0, 0.0, 2e-4}, rate_hz, n, 1), m) < 1e-20);
}

TEST_CASE("the modelled covariance of Allan and Hadamard estimates together matches a simulation") {
  const std::size_t n = 2000;
  const double rate_hz = 10.0;
  const RateNoise noise{0.0, 0.02, 0.0, 2e-3, 0.0};
  const std::vector<VarianceEstimate> e{{5, 2}, {5, 3}, {50, 2}, {50, 3}, {200, 3}};
  const int runs = 400;
  std::vector<std::vector<double>> a(e.size());
  for (int s = 1; s <= runs; ++s) {
    const std::vector<double> y = generate_rate_noise(noise, rate_hz, n, static_cast<std::uint64_t>(s));
    for (std::size_t i = 0; i < e.size(); ++i) a[i].push_back(e[i].differences == 2 ? avar_at(y, e[i].m) : hvar_at(y, e[i].m));
  }
  const AvarCovariance cov(e, n, 1.0 / rate_hz);
  const Eigen::MatrixXd model = cov.covariance({0.0, noise.arw * noise.arw, 0.0, noise.rrw * noise.rrw / 3.0});
  auto covariance = [&](std::size_t i, std::size_t j) { return sample_covariance(a[i], a[j]); };
  for (std::size_t i = 0; i < e.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    INFO("m " << e[i].m << ", differences " << e[i].differences);
    CHECK(covariance(i, i) / model(ii, ii) == Approx(1.0).margin(0.25));
  }
  // The Allan and Hadamard estimates at one tau: strongly, not fully, correlated.
  for (std::size_t i : {0u, 2u}) {
    const auto ii = static_cast<Eigen::Index>(i);
    const double simulated = covariance(i, i + 1) / std::sqrt(covariance(i, i) * covariance(i + 1, i + 1));
    const double modelled = model(ii, ii + 1) / std::sqrt(model(ii, ii) * model(ii + 1, ii + 1));
    INFO("m " << e[i].m << ": simulated correlation " << simulated << ", modelled " << modelled);
    CHECK(simulated == Approx(modelled).margin(0.08));
    CHECK(modelled < 0.99);
  }
}

TEST_CASE("synthetic records have the Allan variance of their IEEE 952 terms") {
  const double rate_hz = 10.0;
  const std::size_t n = 20000;
  struct Case {
    RateNoise noise;
    NoiseTerm term;
    double value;
  };
  const Case cases[] = {
      {{0.0, 0.02, 0.0, 0.0, 0.0}, NoiseTerm::angle_random_walk, 0.02},
      {{0.005, 0.0, 0.0, 0.0, 0.0}, NoiseTerm::quantisation, 0.005},
      {{0.0, 0.0, 0.0, 1e-3, 0.0}, NoiseTerm::rate_random_walk, 1e-3},
      {{0.0, 0.0, 1e-3, 0.0, 0.0}, NoiseTerm::bias_instability, 1e-3},
  };
  for (const Case& c : cases) {
    INFO(noise_term_name(c.term));
    // Mean over 10 records at a cluster time well inside the record: m = 40
    // (EDF about 5000 in all: the mean is known to 2 %).
    double mean = 0.0;
    for (std::uint64_t s = 1; s <= 10; ++s) mean += avar_at(generate_rate_noise(c.noise, rate_hz, n, s), 40) / 10.0;
    const double tau = 40.0 / rate_hz;
    const double want = avar_coefficient(c.term, c.value) * std::pow(tau, noise_term_power(c.term));
    CHECK(mean == Approx(want).epsilon(0.05));
  }
  const std::vector<double> ramp = generate_rate_noise({0.0, 0.0, 0.0, 0.0, 2e-4}, rate_hz, n, 1);
  CHECK(avar_at(ramp, 40) == Approx(avar_coefficient(NoiseTerm::rate_ramp, 2e-4) * 16.0).epsilon(1e-9));
}

TEST_CASE("white noise and a random walk: both covered, no bias instability reported, over 4 records", "[sweep]") {
  // Issue 20's record, shortened to 800 s at 50 Hz (ARW 0.6 deg/sqrt(h),
  // RRW 43.2 deg/h/sqrt(h) made 4x larger so that 800 s show it). In so
  // short a record the random walk is not always told from the rest: then
  // its upper bound must hold the truth.
  const double n_true = 0.01;
  const double k_true = 8e-4;
  int n_covered = 0;
  int k_covered = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, n_true, 0.0, k_true, 0.0}, 50.0, 40000, seed);
    const AllanResult r = allan_deviation(y, 50.0);
    const TermEstimate& n = r.fit.term(NoiseTerm::angle_random_walk);
    const TermEstimate& k = r.fit.term(NoiseTerm::rate_random_walk);
    INFO("seed " << seed << ": N " << n.value << " [" << n.ci_low << ", " << n.ci_high << "], K " << k.value << " ["
                 << k.ci_low << ", " << k.ci_high << "], bound " << k.upper_bound);
    n_covered += n.included && n.ci_low <= n_true && n_true <= n.ci_high;
    k_covered += k.included ? (k.ci_low <= k_true && k_true <= k.ci_high) : k_true <= k.upper_bound;
    CHECK_FALSE(r.fit.term(NoiseTerm::bias_instability).included);
  }
  CHECK(n_covered >= 3);
  CHECK(k_covered >= 3);
}

TEST_CASE("the fit finds a bias instability that is there, its 95 % interval covering the truth in >= 5 of 6 records", "[sweep]") {
  // 20 min at 25 Hz of angle random walk and a 10 deg/h bias instability.
  const double b_true = 10.0 / 3600.0;
  int covered = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, 0.01, b_true, 0.0, 0.0}, 25.0, 30000, seed);
    const AllanResult r = allan_deviation(y, 25.0);
    const TermEstimate& b = r.fit.term(NoiseTerm::bias_instability);
    INFO("seed " << seed << ": B " << b.value << " [" << b.ci_low << ", " << b.ci_high << "], bound " << b.upper_bound);
    covered += b.included ? (b.ci_low <= b_true && b_true <= b.ci_high) : b_true <= b.upper_bound;
  }
  CHECK(covered >= 5);
}

TEST_CASE("a rate random walk and a rate ramp together: both resolved and covered in >= 5 of 6 records", "[sweep]") {
  // 3 h at 10 Hz: white rate noise, issue 20's random walk and a 129.6 deg/h
  // per hour ramp, which dominates the Allan variance beyond tau ~ 300 s.
  // The Allan variance alone cannot apportion the rise between the two (the
  // ramp was covered in fewer than 5 of these 6 records); the Hadamard
  // variance is blind to the ramp and sees the random walk alone.
  const double k_true = 2e-4;
  const double r_true = 1e-5;
  int k_found = 0;
  int r_found = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, 0.01, 0.0, k_true, r_true}, 10.0, 108000, seed);
    const AllanResult r = allan_deviation(y, 10.0);
    const TermEstimate& k = r.fit.term(NoiseTerm::rate_random_walk);
    const TermEstimate& ramp = r.fit.term(NoiseTerm::rate_ramp);
    INFO("seed " << seed << ": K " << k.value << " [" << k.ci_low << ", " << k.ci_high << "], bound " << k.upper_bound
                 << "; R " << ramp.value << " [" << ramp.ci_low << ", " << ramp.ci_high << "]");
    k_found += k.included && k.ci_low <= k_true && k_true <= k.ci_high;
    r_found += ramp.included && ramp.ci_low <= r_true && r_true <= ramp.ci_high;
  }
  CHECK(k_found >= 5);
  CHECK(r_found >= 5);
}

TEST_CASE("a term not resolved still carries its value if present, within its upper bound, a resolved term's value is its own") {
  // White noise and a random walk, 800 s at 50 Hz (as above): the bias
  // instability and the ramp are absent, the random walk often unresolved.
  int unresolved_with_value = 0;  // the branch below must run, or the test proves nothing
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, 0.01, 0.0, 8e-4, 0.0}, 50.0, 40000, seed);
    const AllanResult r = allan_deviation(y, 50.0);
    for (NoiseTerm t : kAllNoiseTerms) {
      const TermEstimate& e = r.fit.term(t);
      INFO("seed " << seed << ", " << noise_term_name(t) << ": value " << e.value << ", if present " << e.value_if_present
                   << ", bound " << e.upper_bound);
      if (e.included) {
        CHECK(e.value_if_present == 0.0);
        CHECK(e.upper_bound == 0.0);
      } else if (e.value_if_present > 0.0) {
        ++unresolved_with_value;
        CHECK(e.value == 0.0);
        CHECK(e.value_if_present <= e.upper_bound);
      }
    }
  }
  CHECK(unresolved_with_value >= 4);
}

TEST_CASE("a rate random walk beside a bias instability, when not resolved, is still estimated within a factor 2 in >= 5 of 6 records", "[sweep]") {
  // 3 h at 10 Hz of white rate noise, a 10 deg/h bias instability and issue
  // 20's random walk: the record type where the random walk is unresolved
  // in about half the records (docs/ALLAN.md). Reporting nothing for it
  // would be a 100 % error; its value if present (here from the REML of the
  // block means) is what the record says of it.
  const double k_true = 2e-4;
  int close = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, 0.01, 10.0 / 3600.0, k_true, 0.0}, 10.0, 108000, seed);
    const AllanResult r = allan_deviation(y, 10.0);
    const TermEstimate& k = r.fit.term(NoiseTerm::rate_random_walk);
    const double estimate = k.included ? k.value : k.value_if_present;
    INFO("seed " << seed << ": K resolved " << k.included << ", estimate " << estimate << ", bound " << k.upper_bound);
    close += estimate > 0.5 * k_true && estimate < 2.0 * k_true;
  }
  CHECK(close >= 5);
}
