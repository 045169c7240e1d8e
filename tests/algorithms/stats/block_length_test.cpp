// The moving-block bootstrap's block length from a series' own autocovariance.
#include "gyrotc/algorithms/stats/block_length.hpp"

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

// A first-order Gauss-Markov series of time constant tau (samples) plus white noise.
std::vector<double> markov_series(double tau, double white, std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit;
  const double phi = std::exp(-1.0 / tau);
  double x = unit(rng);
  std::vector<double> out;
  for (std::size_t i = 0; i < n; ++i) {
    x = phi * x + std::sqrt(1.0 - phi * phi) * unit(rng);
    out.push_back(x + white * unit(rng));
  }
  return out;
}

}  // namespace

TEST_CASE("a white series is redrawn sample by sample") {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> unit;
  std::vector<double> white;
  for (int i = 0; i < 10000; ++i) white.push_back(unit(rng));
  CHECK(stats::block_bootstrap_length(white) < 3.0);
}

TEST_CASE("a correlated series gets blocks that grow with its correlation time") {
  const double short_blocks = stats::block_bootstrap_length(markov_series(20.0, 1.0, 12000, 3));
  const double long_blocks = stats::block_bootstrap_length(markov_series(200.0, 1.0, 12000, 3));
  INFO(short_blocks << " and " << long_blocks << " samples");
  CHECK(short_blocks > 5.0);
  CHECK(long_blocks > 3.0 * short_blocks);
  CHECK(long_blocks <= 4000.0);
}

TEST_CASE("a series too short for a block length is refused") {
  CHECK_THROWS_AS(stats::block_bootstrap_length(std::vector<double>(10, 1.0)), std::invalid_argument);
}
