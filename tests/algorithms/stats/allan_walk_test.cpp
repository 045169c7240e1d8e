// The rate random walk by REML on a record's block means (allan_walk.hpp):
// right on average, with a standard error that describes its scatter, and
// blind to a rate ramp.
#include <cmath>
#include <vector>

#include "gyrotc/algorithms/model/rate_noise.hpp"
#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/allan_walk.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::stats;
using gyrotc::model::generate_rate_noise;

namespace {

// White rate noise (ARW 0.6 deg/sqrt(h)) and a random walk, 1 h at 10 Hz.
constexpr double kArw = 0.01;
constexpr double kRrw = 4e-4;
constexpr std::size_t kSamples = 36000;

std::array<double, 4> start_coefficients(double walk) {
  return {0.0, avar_coefficient(NoiseTerm::angle_random_walk, kArw), 0.0, avar_coefficient(NoiseTerm::rate_random_walk, walk)};
}

}  // namespace

TEST_CASE("REML of the block means finds the random walk, its standard error the size of its scatter over 30 records") {
  double sum_z = 0.0;
  double sum_z2 = 0.0;
  const int records = 30;
  const double truth = std::log(avar_coefficient(NoiseTerm::rate_random_walk, kRrw));
  for (int seed = 1; seed <= records; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, kArw, 0.0, kRrw, 0.0}, 10.0, kSamples, static_cast<std::uint64_t>(seed));
    // Started a factor 3 off: the optimum, not the start, is reported.
    const WalkEstimate w = reml_random_walk(y, 10.0, start_coefficients(3.0 * kRrw), 200);
    REQUIRE(w.ok);
    CHECK(w.differences == 199);
    const double z = (std::log(w.walk_coefficient) - truth) / w.relative_se;
    sum_z += z;
    sum_z2 += z * z;
  }
  const double mean = sum_z / records;
  const double mean_square = sum_z2 / records;
  INFO("standardised errors: mean " << mean << ", mean square " << mean_square);
  // For right standard errors the mean square is chi^2_30 / 30: 0.53..1.57 at 98 %.
  CHECK(mean_square > 0.53);
  CHECK(mean_square < 1.57);
  CHECK(std::fabs(mean) < 0.6);
}

TEST_CASE("REML of the random walk is the same with a rate ramp added: the ramp is the differences' mean, which it removes") {
  const std::vector<double> plain = generate_rate_noise({0.0, kArw, 0.0, kRrw, 0.0}, 10.0, kSamples, 7);
  std::vector<double> ramped = plain;
  for (std::size_t i = 0; i < ramped.size(); ++i) ramped[i] += 1e-4 * static_cast<double>(i) / 10.0;  // 0.36 deg/s per hour
  const WalkEstimate a = reml_random_walk(plain, 10.0, start_coefficients(kRrw), 200);
  const WalkEstimate b = reml_random_walk(ramped, 10.0, start_coefficients(kRrw), 200);
  REQUIRE(a.ok);
  REQUIRE(b.ok);
  CHECK(b.walk_coefficient == Approx(a.walk_coefficient).epsilon(1e-6));
  CHECK(b.relative_se == Approx(a.relative_se).epsilon(1e-6));
}

TEST_CASE("REML estimates a bias instability beside the walk when the model has one") {
  const double b_true = 10.0 / 3600.0;
  const std::vector<double> y = generate_rate_noise({0.0, kArw, b_true, kRrw, 0.0}, 10.0, kSamples, 3);
  std::array<double, 4> c = start_coefficients(kRrw);
  c[2] = avar_coefficient(NoiseTerm::bias_instability, 0.5 * b_true);
  const WalkEstimate w = reml_random_walk(y, 10.0, c, 200);
  REQUIRE(w.ok);
  const double b = term_value(NoiseTerm::bias_instability, w.flicker_coefficient);
  INFO("B " << b << " (truth " << b_true << "), K " << term_value(NoiseTerm::rate_random_walk, w.walk_coefficient));
  CHECK(b > 0.6 * b_true);
  CHECK(b < 1.6 * b_true);
}

TEST_CASE("REML refuses what it cannot estimate: no walk to start from, too few blocks, a record shorter than its blocks") {
  const std::vector<double> y = generate_rate_noise({0.0, kArw, 0.0, kRrw, 0.0}, 10.0, 1000, 1);
  CHECK_FALSE(reml_random_walk(y, 10.0, start_coefficients(0.0), 200).ok);
  CHECK_FALSE(reml_random_walk(y, 10.0, start_coefficients(kRrw), 3).ok);
  CHECK_FALSE(reml_random_walk(std::span<const double>(y).first(100), 10.0, start_coefficients(kRrw), 200).ok);
}

TEST_CASE("allan takes the walk from the block means only where it hides below another noise at the block length") {
  AllanOptions off;
  off.walk_blocks = 0;
  auto walk = [](const AllanResult& r) {
    const TermEstimate& k = r.fit.term(NoiseTerm::rate_random_walk);
    return k.included ? k.value : k.value_if_present;
  };
  // A random walk alone rules every cluster time: the short clusters know
  // it best, and the fit's value stands.
  const std::vector<double> alone = generate_rate_noise({0.0, 0.0, 0.0, kRrw, 0.0}, 10.0, kSamples, 5);
  CHECK(walk(allan_deviation(alone, 10.0)) == walk(allan_deviation(alone, 10.0, off)));
  // Beside a 10 deg/h bias instability it shows only above ~ 250 s, far
  // above the 7.2 s blocks: the REML value replaces the fit's.
  const std::vector<double> hidden = generate_rate_noise({0.0, kArw, 10.0 / 3600.0, kRrw, 0.0}, 10.0, kSamples, 5);
  const AllanResult refined = allan_deviation(hidden, 10.0);
  const double fit_only = walk(allan_deviation(hidden, 10.0, off));
  INFO("truth " << kRrw << ", REML " << walk(refined) << ", fit only " << fit_only);
  // Replaced (the REML path ran), and by a value within a factor 2 of the
  // truth: a replacement by anything else would pass the first check alone.
  // (Closer than the fit's own is not claimed: on this seed REML is 12 % low,
  // the fit 10 %; the accuracy over seeds is allan_noise_test's.)
  CHECK(walk(refined) != fit_only);
  CHECK(walk(refined) > 0.5 * kRrw);
  CHECK(walk(refined) < 2.0 * kRrw);
}

TEST_CASE("records with no walk to speak of keep a finite upper bound for it, over 20 seeds", "[sweep]") {
  // 6 s of white noise and a ramp: 500 blocks of one sample each, where the
  // walk's REML value is near 0 and its log-normal interval reached infinity.
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const std::vector<double> y = generate_rate_noise({0.0, kArw, 0.0, 0.0, 0.01}, 100.0, 600, seed);
    const AllanResult r = allan_deviation(y, 100.0);
    REQUIRE(r.fit.valid);
    for (NoiseTerm t : kAllNoiseTerms) {
      const TermEstimate& e = r.fit.term(t);
      INFO("seed " << seed << ", " << noise_term_name(t) << ": bound " << e.upper_bound << ", interval " << e.ci_low
                   << ".." << e.ci_high);
      CHECK(std::isfinite(e.upper_bound));
      CHECK(std::isfinite(e.ci_high));
    }
  }
}
