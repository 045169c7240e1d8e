// The split between a sweep's upward and downward passes, on records made
// here (not by the plant simulator): a triangle of the casing at 0.6 C/min
// with dwells at its ends, the gyro reading a linear bias curve or a bowl at
// the die, with white noise and a wandering bias of its own.
#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

constexpr double kSlopeMvPerC = 0.5;
constexpr double kRateCPerS = 0.6 / 60.0;

struct UpDownRecord {
  std::vector<double> time_s, sensor_c, gyro_mv;
};

struct Gyro {
  double low_c = 20.0;  // the sweep's ends
  double high_c = 40.0;
  double bowl_mv_per_c2 = 0.0;  // 0: the line kSlopeMvPerC; else a bowl lowest at 35 C
  double wander_mv = 0.0;       // a first-order wander of the bias
  double wander_tau_s = 100.0;
  std::uint64_t seed = 5;
};

// low -> high C, 300 s dwell, high -> low C, 300 s dwell; a row a second. The
// die follows the casing through a first-order lag (exact step); the bias is
// the curve at the die + hysteresis_mv * (the sign of the casing's motion).
UpDownRecord sweep(double die_lag_s, double hysteresis_mv, double noise_mv, Gyro gyro = {}) {
  UpDownRecord r;
  std::mt19937_64 rng(gyro.seed);
  std::normal_distribution<double> normal(0.0, noise_mv);
  std::normal_distribution<double> unit;
  const double phi = std::exp(-1.0 / gyro.wander_tau_s);
  double wander_mv = gyro.wander_mv * unit(rng);
  const double ramp_s = (gyro.high_c - gyro.low_c) / kRateCPerS;
  double die_c = gyro.low_c;
  for (double t = 0.0; t < 2.0 * ramp_s + 600.0; t += 1.0) {
    double casing_c = gyro.high_c;
    double direction = 0.0;
    if (t < ramp_s) {
      casing_c = gyro.low_c + kRateCPerS * t;
      direction = 1.0;
    } else if (t >= ramp_s + 300.0 && t < 2.0 * ramp_s + 300.0) {
      casing_c = gyro.high_c - kRateCPerS * (t - ramp_s - 300.0);
      direction = -1.0;
    } else if (t >= 2.0 * ramp_s + 300.0) {
      casing_c = gyro.low_c;
    }
    die_c = die_lag_s > 0.0 ? casing_c + (die_c - casing_c) * std::exp(-1.0 / die_lag_s) : casing_c;
    wander_mv = phi * wander_mv + gyro.wander_mv * std::sqrt(1.0 - phi * phi) * unit(rng);
    const double curve_mv = gyro.bowl_mv_per_c2 > 0.0 ? gyro.bowl_mv_per_c2 * (die_c - 35.0) * (die_c - 35.0)
                                                      : kSlopeMvPerC * die_c;
    r.time_s.push_back(t);
    r.sensor_c.push_back(casing_c);
    r.gyro_mv.push_back(2500.0 + curve_mv + hysteresis_mv * direction + wander_mv + normal(rng));
  }
  return r;
}

calibrate::UpDownDifference split_of(const UpDownRecord& r) {
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
  UpDownRecord r = sweep(0.0, 0.3, 0.05);
  // Cut the downward pass short at 30 C: bins above 30 C were crossed both
  // ways, those below only upwards.
  UpDownRecord cut;
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

// A sweep as the self-calibration's, 10..60 C, over a bowl whose slope runs
// from -1 to +1 mV/C: a 60 s lag splits the passes by -1.2 .. +1.2 mV, a
// hysteresis by its width everywhere. The noise: 0.05 mV white and a 0.1 mV
// wander of 100 s, as a MEMS gyro's bias instability.
Gyro bowl(std::uint64_t seed) { return {10.0, 60.0, 0.02, 0.1, 100.0, seed}; }

TEST_CASE("on a bowl the die's lag is told from a hysteresis: a 60 s lag and none") {
  const calibrate::LagAndHysteresis s = split_of(sweep(60.0, 0.0, 0.05, bowl(5))).separation;
  REQUIRE(s.separated);
  INFO("lag " << s.die_lag_s << " +/- " << s.die_lag_s_std << " s, split " << s.split_mv << " +/- " << s.split_mv_std);
  CHECK(std::fabs(s.die_lag_s - 60.0) < 3.0 * s.die_lag_s_std);
  CHECK(s.die_lag_s_std < 6.0);
  CHECK(std::fabs(s.split_mv) < 3.0 * s.split_mv_std);
}

TEST_CASE("on a bowl a hysteresis is told from the lag: 0.3 mV each way beside a 60 s lag") {
  const calibrate::LagAndHysteresis s = split_of(sweep(60.0, 0.3, 0.05, bowl(5))).separation;
  REQUIRE(s.separated);
  INFO("lag " << s.die_lag_s << " +/- " << s.die_lag_s_std << " s, split " << s.split_mv << " +/- " << s.split_mv_std);
  CHECK(std::fabs(s.split_mv - 0.6) < 3.0 * s.split_mv_std);
  CHECK(s.split_mv_std < 0.1);
  CHECK(std::fabs(s.die_lag_s - 60.0) < 3.0 * s.die_lag_s_std);
}

TEST_CASE("the lag's and the split's errors over records of other noise are what their standard errors say", "[sweep]") {
  // 40 records, each its own noise: the rms over them of (estimate - truth)
  // / standard error is 1 for errors that say what they should. Read off the
  // bins' scatter alone (a Newey-West window over the bins), it was 1.7 for
  // the lag and 1.5 for the split on 60 records of this kind (seeds 1-60);
  // with the wander left out of the noise model, 5.9 and 5.4 on these.
  constexpr int kRecords = 40;
  double lag_z2 = 0.0, split_z2 = 0.0, lag_sum = 0.0, split_sum = 0.0;
  for (int k = 0; k < kRecords; ++k) {
    const calibrate::LagAndHysteresis s =
        split_of(sweep(60.0, 0.2, 0.05, bowl(100 + static_cast<std::uint64_t>(k)))).separation;
    REQUIRE(s.separated);
    lag_z2 += std::pow((s.die_lag_s - 60.0) / s.die_lag_s_std, 2);
    split_z2 += std::pow((s.split_mv - 0.4) / s.split_mv_std, 2);
    lag_sum += s.die_lag_s - 60.0;
    split_sum += s.split_mv - 0.4;
  }
  const double lag_z = std::sqrt(lag_z2 / kRecords);
  const double split_z = std::sqrt(split_z2 / kRecords);
  INFO("rms z: lag " << lag_z << ", split " << split_z << "; mean error: lag " << lag_sum / kRecords << " s, split "
                     << split_sum / kRecords << " mV");
  CHECK(lag_z > 0.77);
  CHECK(lag_z < 1.3);
  CHECK(split_z > 0.77);
  CHECK(split_z < 1.3);
}

TEST_CASE("on a straight curve the lag and a hysteresis are one column, and the split says so") {
  const calibrate::UpDownDifference d = split_of(sweep(60.0, 0.3, 0.05));
  CHECK_FALSE(d.separation.separated);
  CHECK(d.separation.why_not.find("slope hardly changes") != std::string::npos);
  CHECK(std::isnan(d.separation.die_lag_s));
}
