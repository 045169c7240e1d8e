#include <cmath>
#include <random>
#include <vector>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::identify;

// Reference values: the 5 % and 1 % points of the F distribution from the
// standard tables (e.g. NIST/SEMATECH e-Handbook, section 1.3.6.7.3).
TEST_CASE("f_sf gives the tail probabilities of the F distribution's tabulated critical values") {
  CHECK(f_sf(5.318, 1, 8) == Approx(0.05).margin(2e-4));
  CHECK(f_sf(4.459, 2, 8) == Approx(0.05).margin(2e-4));
  CHECK(f_sf(8.649, 2, 8) == Approx(0.01).margin(1e-4));
  CHECK(f_sf(2.534, 5, 20) == Approx(0.0625).margin(0.01));  // between the 5 % (2.711) and 10 % (2.158) points
  CHECK(f_sf(4.351, 1, 20) == Approx(0.05).margin(2e-4));
  CHECK(f_sf(0.0, 3, 10) == 1.0);
}

TEST_CASE("chi_square_sf gives the tail probabilities of tabulated chi-square critical values") {
  CHECK(chi_square_sf(3.841, 1) == Approx(0.05).margin(1e-4));
  CHECK(chi_square_sf(15.086, 5) == Approx(0.01).margin(1e-4));
  CHECK(chi_square_sf(10.828, 1) == Approx(0.001).margin(1e-5));
}

TEST_CASE("the long-run variance factor of AR(1) noise approaches (1+rho)/(1-rho), of white noise, 1") {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> white(200000), ar(200000);
  double state = 0.0;
  for (std::size_t i = 0; i < white.size(); ++i) {
    white[i] = normal(rng);
    state = 0.5 * state + normal(rng);
    ar[i] = state;
  }
  CHECK(long_run_variance_factor(white) == Approx(1.0).margin(0.05));
  // Bartlett weights bias the factor low at a finite bandwidth; 60 lags
  // leave that below 5 % for rho = 0.5.
  CHECK(long_run_variance_factor(ar, 60) == Approx(3.0).epsilon(0.06));
}
