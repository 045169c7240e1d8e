// A calibration's own error bound, on sweep records made here (not by the
// plant simulator): the casing at rest at 25 C, down to 10 C, held, up to
// 60 C, held and back at 0.6 C/min, read once a second in 1/16 C steps; the
// gyro reads a bowl at a die 40 s behind the casing, with white noise and a
// wander (a first-order Gauss-Markov bias). Each record is binned and fitted
// as `gyrotc calibrate` does (the die's lag from the passes, 1 C bins, auto
// with a 2 C block, the bound about the choice's best candidate) and its
// bound compared with the fit's true error.
#include "gyrotc/algorithms/calibrate/calibration_bound.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/calibrate/temperature_bins.hpp"
#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"
#include "sweep_path.hpp"

using namespace gyrotc;

namespace {

struct BoundRecord {
  std::vector<double> time_s, sensor_c, gyro_mv;
};

struct BoundUnit {
  double die_lag_s = 40.0;
  double white_mv = 0.3;
  double wander_mv = 0.09;
  double wander_tau_s = 100.0;
  std::uint64_t seed = 1;
};

double bowl_mv(double die_c) { return 2500.0 + 0.3 * (die_c - 30.0) + 0.004 * (die_c - 30.0) * (die_c - 30.0); }

// The casing's path: 300 s at 25 C, down to 10 C, 600 s there, up to 60 C,
// 600 s there, back to 25 C, at 0.6 C/min.
double casing_path_c(double t) {
  constexpr test::SweepLeg kLegs[] = {{10.0, 600.0}, {60.0, 600.0}, {25.0, 0.0}};
  return test::sweep_casing_c(t, 25.0, 300.0, kLegs, 0.01);
}

BoundRecord bound_sweep(const BoundUnit& u) {
  BoundRecord r;
  std::mt19937_64 rng(u.seed);
  std::normal_distribution<double> unit;
  const double phi = std::exp(-1.0 / u.wander_tau_s);
  double wander = u.wander_mv * unit(rng);
  double die_c = 25.0;
  for (int i = 0; i < 11500; ++i) {  // 300 + 1500 + 600 + 5000 + 600 + 3500 s
    const double t = i;
    for (int k = 1; k <= 10; ++k) {
      const double casing = casing_path_c(t - 1.0 + 0.1 * k);
      die_c = casing + (die_c - casing) * std::exp(-0.1 / u.die_lag_s);
    }
    wander = phi * wander + u.wander_mv * std::sqrt(1.0 - phi * phi) * unit(rng);
    r.time_s.push_back(t);
    r.sensor_c.push_back(test::ds18b20_steps_c(casing_path_c(t)));
    r.gyro_mv.push_back(bowl_mv(die_c) + wander + u.white_mv * unit(rng));
  }
  return r;
}

struct Calibrated {
  fit::MethodFit fit;
  calibrate::CalibrationBound bound;
  double true_error_mv = 0.0;  // the largest |fit - truth| over the bound's grid
};

Calibrated calibrate_record(const BoundRecord& r, int replicates) {
  const calibrate::LagAndHysteresis lag =
      calibrate::up_down_difference(r.time_s, r.sensor_c, r.gyro_mv).separation;
  const double lag_s = lag.separated ? lag.die_lag_s : 0.0;
  const double lag_s_std = lag.separated ? lag.die_lag_s_std : 0.0;
  const std::vector<double> die_c = calibrate::die_temperature_c(r.time_s, r.sensor_c, lag_s);
  const calibrate::TemperatureBins bins = calibrate::bin_by_temperature(die_c, r.gyro_mv, 1.0);
  fit::MethodOptions method;
  method.cv_block_c = 2.0;
  method.smoothing.block_c = 2.0;
  Calibrated c{fit::fit_method(bins.temp_c, bins.gyro_mv, method), {}, 0.0};
  calibrate::BoundOptions options;
  options.replicates = replicates;
  const fit::MethodFit pilot = calibrate::fit_pilot(bins.temp_c, bins.gyro_mv, c.fit, method);
  c.bound = calibrate::recording_bound(r.time_s, r.sensor_c, r.gyro_mv, lag_s, lag_s_std, pilot.model, method, options);
  for (double t : c.bound.temp_c) {
    c.true_error_mv = std::max(c.true_error_mv, std::fabs(c.fit.model.bias_mv(t) - bowl_mv(t)));
  }
  return c;
}

}  // namespace

TEST_CASE("the bound covers the calibrated range with its grid and states one figure for the whole of it") {
  const Calibrated c = calibrate_record(bound_sweep({}), 100);
  REQUIRE(c.bound.temp_c.size() == c.bound.bound_mv.size());
  CHECK(c.bound.temp_c.front() < 11.0);
  CHECK(c.bound.temp_c.back() > 59.0);
  CHECK(c.bound.replicates == 100);
  const double widest = *std::max_element(c.bound.bound_mv.begin(), c.bound.bound_mv.end());
  // All at once is wider than anywhere alone, and no wider than a few times it.
  CHECK(c.bound.range_bound_mv >= widest);
  CHECK(c.bound.range_bound_mv < 3.0 * widest);
}

TEST_CASE("a noisier record gets a wider bound") {
  BoundUnit noisy;
  noisy.wander_mv = 0.36;
  const Calibrated quiet = calibrate_record(bound_sweep({}), 60);
  const Calibrated loud = calibrate_record(bound_sweep(noisy), 60);
  INFO(quiet.bound.range_bound_mv << " mV against " << loud.bound.range_bound_mv << " mV");
  CHECK(loud.bound.range_bound_mv > 2.0 * quiet.bound.range_bound_mv);
}

TEST_CASE("the stated bound holds the true curve on most records, and is not loose", "[sweep]") {
  int held = 0;
  std::vector<double> ratios;
  const int records = 40;
  for (int k = 0; k < records; ++k) {
    BoundUnit u;
    u.seed = 100 + static_cast<std::uint64_t>(k);
    const Calibrated c = calibrate_record(bound_sweep(u), 200);
    held += c.true_error_mv <= c.bound.range_bound_mv ? 1 : 0;
    ratios.push_back(c.true_error_mv / c.bound.range_bound_mv);
  }
  std::sort(ratios.begin(), ratios.end());
  const double median = 0.5 * (ratios[records / 2 - 1] + ratios[records / 2]);
  const auto narrower = std::count_if(ratios.begin(), ratios.end(), [](double r) { return r <= 0.8; });
  INFO("held " << held << " of " << records << " (" << narrower << " by a bound 20 % narrower); median true/bound "
               << median);
  // 95 % nominal would hold about 38 of 40; these records' bounds held 35 (the
  // misses at the range's ends, where the die's lag estimated from this noisy a
  // record counts most): the shortfall is open (docs/SELFCAL.md), and this
  // keeps it from growing. A bound 20 % narrower holds 31, and fails it.
  CHECK(held >= 34);
  CHECK(median >= 0.3);
}

TEST_CASE("a table's bound comes from its points' residuals") {
  std::vector<double> temp_c, gyro_mv;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> unit;
  for (double t = -40.0; t <= 80.0; t += 5.0) {
    temp_c.push_back(t);
    gyro_mv.push_back(bowl_mv(t) + 0.2 * unit(rng));
  }
  fit::MethodOptions method;
  method.method = fit::Method::polynomial;
  method.orders = {2};
  const fit::MethodFit f = fit::fit_method(temp_c, gyro_mv, method);
  calibrate::BoundOptions options;
  options.replicates = 200;
  const calibrate::CalibrationBound b = calibrate::table_bound(temp_c, gyro_mv, f.dof, f.model, method, options);
  CHECK(b.block_s == 0.0);
  // A quadratic through 25 points of 0.2 mV noise: about 2 x 0.2 x sqrt(3 / 25) in the middle.
  CHECK(calibrate::bound_at_mv(b, 20.0) == Approx(0.14).epsilon(0.5));
  CHECK(calibrate::bound_at_mv(b, 80.0) > calibrate::bound_at_mv(b, 20.0));
}

TEST_CASE("the pilot is the candidate the cross-validation found best, not the simpler one the rule chose") {
  const std::vector<double> temp_c = {0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0};
  std::vector<double> gyro_mv;
  for (double t : temp_c) gyro_mv.push_back(bowl_mv(t));
  fit::MethodOptions line;
  line.method = fit::Method::polynomial;
  line.orders = {1};
  fit::MethodFit f = fit::fit_method(temp_c, gyro_mv, line);
  f.candidates = {{"poly 2", {}, 0.0, true, true}, {"poly 5", {}, 0.0, true, false}, {"smooth", {}, 0.0, false, false}};
  f.candidates[0].score.mse = 1.1;
  f.candidates[1].score.mse = 1.0;
  f.candidates[2].score.mse = 1.3;
  const fit::MethodOptions pilot = calibrate::pilot_options(f, {});
  CHECK(pilot.method == fit::Method::polynomial);
  CHECK(pilot.orders == std::vector<int>{5});
  f.candidates[2].score.mse = 0.5;
  CHECK(calibrate::pilot_options(f, {}).method == fit::Method::smoothing);
}

TEST_CASE("a smoothing spline's pilot keeps twice the parameters its choice took") {
  std::vector<double> temp_c, gyro_mv;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> unit;
  for (double t = 0.0; t <= 60.0; t += 1.0) {
    temp_c.push_back(t);
    gyro_mv.push_back(bowl_mv(t) + 1.5 * std::sin(t / 4.0) + 0.1 * unit(rng));
  }
  fit::MethodOptions method;
  method.method = fit::Method::smoothing;
  const fit::MethodFit f = fit::fit_method(temp_c, gyro_mv, method);
  const fit::MethodFit pilot = calibrate::fit_pilot(temp_c, gyro_mv, f, method);
  CHECK(pilot.method == fit::Method::smoothing);
  CHECK(pilot.dof == Approx(std::min(2.0 * f.dof, 59.0)).epsilon(0.02));
}

TEST_CASE("a record too short to bootstrap is refused") {
  BoundRecord r = bound_sweep({});
  r.time_s.resize(10);
  r.sensor_c.resize(10);
  r.gyro_mv.resize(10);
  fit::MethodOptions method;
  method.method = fit::Method::polynomial;
  method.orders = {1};
  const fit::BiasModel line = fit::BiasModel::paper_reference();
  CHECK_THROWS_AS(calibrate::recording_bound(r.time_s, r.sensor_c, r.gyro_mv, 0.0, 0.0, line, method, {}),
                  std::invalid_argument);
}
