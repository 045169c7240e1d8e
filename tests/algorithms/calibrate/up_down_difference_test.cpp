// The split between a sweep's upward and downward passes, on records made
// here (not by the plant simulator): a triangle of the casing at 0.6 C/min
// with dwells at its ends, the gyro reading a linear bias curve at the die.
#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"

#include <cmath>
#include <random>
#include <vector>

#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

constexpr double kSlopeMvPerC = 0.5;
constexpr double kRateCPerS = 0.6 / 60.0;

struct Record {
  std::vector<double> time_s, sensor_c, gyro_mv;
};

// 20 -> 40 C, 300 s dwell, 40 -> 20 C, 300 s dwell; a row a second. The die
// follows the casing through a first-order lag (exact step); the bias is
// slope * die + hysteresis_mv * (the sign of the casing's motion).
Record sweep(double die_lag_s, double hysteresis_mv, double noise_mv) {
  Record r;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, noise_mv);
  const double ramp_s = 20.0 / kRateCPerS;
  double die_c = 20.0;
  double direction = 0.0;
  for (double t = 0.0; t < 2.0 * ramp_s + 600.0; t += 1.0) {
    double casing_c = 40.0;
    direction = 0.0;
    if (t < ramp_s) {
      casing_c = 20.0 + kRateCPerS * t;
      direction = 1.0;
    } else if (t >= ramp_s + 300.0 && t < 2.0 * ramp_s + 300.0) {
      casing_c = 40.0 - kRateCPerS * (t - ramp_s - 300.0);
      direction = -1.0;
    } else if (t >= 2.0 * ramp_s + 300.0) {
      casing_c = 20.0;
    }
    die_c = die_lag_s > 0.0 ? casing_c + (die_c - casing_c) * std::exp(-1.0 / die_lag_s) : casing_c;
    r.time_s.push_back(t);
    r.sensor_c.push_back(casing_c);
    r.gyro_mv.push_back(2500.0 + kSlopeMvPerC * die_c + hysteresis_mv * direction + normal(rng));
  }
  return r;
}

calibrate::UpDownDifference split_of(const Record& r) {
  return calibrate::up_down_difference(r.time_s, r.sensor_c, r.gyro_mv);
}

}  // namespace

TEST_CASE("a die that follows the casing and a bias without hysteresis show no split beyond the noise") {
  const calibrate::UpDownDifference d = split_of(sweep(0.0, 0.0, 0.05));
  CHECK(d.bins.size() >= 18);
  CHECK(d.mean_abs_mv < 0.02);
}

TEST_CASE("a die lagging the casing splits the passes by twice the slope times the lag's distance") {
  // 120 s behind at 0.01 C/s: 1.2 C each way, 2 x 1.2 C x 0.5 mV/C = 1.2 mV.
  const calibrate::UpDownDifference d = split_of(sweep(120.0, 0.0, 0.05));
  CHECK(d.mean_abs_mv == Approx(1.2).epsilon(0.1));
  for (const calibrate::UpDownBin& b : d.bins) CHECK(b.up_mv < b.down_mv);  // warming, the die is cooler
}

TEST_CASE("a bias with hysteresis splits the passes by twice its half-width wherever they cross") {
  const calibrate::UpDownDifference d = split_of(sweep(0.0, 0.3, 0.05));
  CHECK(d.mean_abs_mv == Approx(0.6).epsilon(0.05));
  CHECK(d.max_abs_mv == Approx(0.6).epsilon(0.1));
}

TEST_CASE("the dwells at the ends count for neither pass, and a bin crossed one way only is left out") {
  Record r = sweep(0.0, 0.3, 0.05);
  // Cut the downward pass short at 30 C: bins above 30 C were crossed both
  // ways, those below only upwards.
  Record cut;
  for (std::size_t i = 0; i < r.time_s.size(); ++i) {
    if (r.time_s[i] > 2000.0 + 300.0 + 1000.0) break;  // up (2000 s), dwell, 1000 s down to 30 C
    cut.time_s.push_back(r.time_s[i]);
    cut.sensor_c.push_back(r.sensor_c[i]);
    cut.gyro_mv.push_back(r.gyro_mv[i]);
  }
  const calibrate::UpDownDifference d = split_of(cut);
  REQUIRE_FALSE(d.bins.empty());
  CHECK(d.bins.front().temp_c > 30.0);
  for (const calibrate::UpDownBin& b : d.bins) CHECK(b.up_rows < 150);  // ~100 s a bin at 0.6 C/min, no dwell
}
