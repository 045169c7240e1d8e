// The die's lag from a whole sweep record, on records made here (not by the
// plant simulator): the casing at rest, then down, held, up, held and back
// at 0.6 C/min, read once a second in 1/16 C steps; the gyro reads a straight
// bias curve (where the passes cannot tell a lag from a hysteresis) at a die
// stepped through its lag in 0.1 s steps, with white noise and a wander.
#include "gyrotc/algorithms/calibrate/die_lag_from_record.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"
#include "sweep_path.hpp"

using namespace gyrotc;

namespace {

struct Record {
  std::vector<double> time_s, sensor_c, gyro_mv;
};

struct Unit {
  double die_lag_s = 60.0;
  double hysteresis_mv = 0.0;  // + moving up, - moving down
  double slope_mv_per_c = 2.5;
  double bowl_mv_per_c2 = 0.0;
  double white_mv = 0.05;
  double wander_mv = 0.1;
  double wander_tau_s = 100.0;
  std::uint64_t seed = 3;
};

// The casing's path: 300 s at 25 C, down to 10 C, 400 s there, up to 40 C,
// 400 s there, back to 25 C, 300 s there.
double casing_at(double t, double& direction) {
  constexpr test::SweepLeg kLegs[] = {{10.0, 400.0}, {40.0, 400.0}, {25.0, 300.0}};
  return test::sweep_casing_c(t, 25.0, 300.0, kLegs, 0.01, &direction);
}

Record sweep(const Unit& u) {
  Record r;
  std::mt19937_64 rng(u.seed);
  std::normal_distribution<double> unit;
  const double phi = std::exp(-1.0 / u.wander_tau_s);
  double wander = u.wander_mv * unit(rng);
  double die_c = 25.0;
  double direction = 0.0;
  for (int i = 0; i < 7400; ++i) {  // the path above: 300 + 1500 + 400 + 3000 + 400 + 1500 + 300 s
    const double t = i;
    for (int k = 1; k <= 10; ++k) {
      const double casing = casing_at(t - 1.0 + 0.1 * k, direction);
      die_c = u.die_lag_s > 0.0 ? casing + (die_c - casing) * std::exp(-0.1 / u.die_lag_s) : casing;
    }
    const double casing = casing_at(t, direction);
    wander = phi * wander + u.wander_mv * std::sqrt(1.0 - phi * phi) * unit(rng);
    const double curve = u.slope_mv_per_c * die_c + u.bowl_mv_per_c2 * (die_c - 25.0) * (die_c - 25.0);
    r.time_s.push_back(t);
    r.sensor_c.push_back(test::ds18b20_steps_c(casing));
    r.gyro_mv.push_back(2500.0 + curve + u.hysteresis_mv * direction + wander + u.white_mv * unit(rng));
  }
  return r;
}

calibrate::RecordLag lag_of(const Record& r) {
  return calibrate::die_lag_from_record(r.time_s, r.sensor_c, r.gyro_mv);
}

}  // namespace

TEST_CASE("on a straight curve, where the passes cannot tell a lag from a hysteresis, the record shows the die's lag") {
  const Record r = sweep({});
  REQUIRE_FALSE(calibrate::up_down_difference(r.time_s, r.sensor_c, r.gyro_mv).separation.separated);
  const calibrate::RecordLag lag = lag_of(r);
  INFO(lag.die_lag_s << " +/- " << lag.die_lag_s_std << " s; " << lag.why_not);
  REQUIRE(lag.found);
  CHECK(std::fabs(lag.die_lag_s - 60.0) < 3.0 * lag.die_lag_s_std);
  CHECK(lag.die_lag_s_std < 10.0);
}

TEST_CASE("a hysteresis beside the lag is the split, not a longer lag") {
  Unit u;
  u.hysteresis_mv = 0.3;
  const calibrate::RecordLag lag = lag_of(sweep(u));
  INFO(lag.die_lag_s << " +/- " << lag.die_lag_s_std << " s, split " << lag.split_mv << " mV");
  REQUIRE(lag.found);
  CHECK(std::fabs(lag.die_lag_s - 60.0) < 3.0 * lag.die_lag_s_std);
  CHECK(lag.split_mv == Approx(0.6).margin(0.1));
}

TEST_CASE("a die that keeps up with the sensor: a lag is found on at most 2 of 20 records, and none over 15 s", "[sweep]") {
  int found = 0;
  double longest_s = 0.0;
  for (int k = 0; k < 20; ++k) {
    Unit u;
    u.seed = 700 + static_cast<std::uint64_t>(k);
    u.die_lag_s = 0.0;
    u.hysteresis_mv = k % 2 == 0 ? 0.0 : 0.3;  // the passes split all the same
    const calibrate::RecordLag lag = lag_of(sweep(u));
    if (!lag.found) continue;
    ++found;
    longest_s = std::max(longest_s, lag.die_lag_s);
  }
  INFO(found << " found, the longest " << longest_s << " s");
  CHECK(found <= 2);
  CHECK(longest_s < 15.0);
}

TEST_CASE("the record's lag and its standard error hold the truth over many records, on a bowl as on a line", "[sweep]") {
  double z2 = 0.0;
  int held = 0;
  constexpr int kRecords = 20;
  for (int k = 0; k < kRecords; ++k) {
    Unit u;
    u.seed = 100 + static_cast<std::uint64_t>(k);
    u.die_lag_s = 30.0 + 5.0 * k;
    u.bowl_mv_per_c2 = k % 2 == 0 ? 0.0 : 0.02;
    const calibrate::RecordLag lag = lag_of(sweep(u));
    REQUIRE(lag.found);
    const double z = (lag.die_lag_s - u.die_lag_s) / lag.die_lag_s_std;
    z2 += z * z;
    held += std::fabs(z) < 1.96 ? 1 : 0;
  }
  const double rms_z = std::sqrt(z2 / kRecords);
  INFO("rms z " << rms_z << ", held " << held << " of " << kRecords);
  CHECK(rms_z > 0.6);
  CHECK(rms_z < 1.4);
  CHECK(held >= 16);
}

TEST_CASE("a record whose casing hardly moved, or whose time goes back, is not read for a lag") {
  Record r;
  for (int i = 0; i < 3000; ++i) {
    r.time_s.push_back(i);
    r.sensor_c.push_back(25.0 + 0.5 * std::sin(i / 300.0));
    r.gyro_mv.push_back(2500.0);
  }
  CHECK_FALSE(lag_of(r).found);
  CHECK_THAT(lag_of(r).why_not, Catch::Contains("moved too little"));
  r.time_s[10] = 5.0;
  CHECK_THROWS_AS(lag_of(r), std::invalid_argument);
}
