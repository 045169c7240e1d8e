// The die's temperature from the casing sensor's record (die_temperature.hpp),
// checked against the lag's differential equation integrated here in small
// steps, not against the closed form the code uses.
#include "gyrotc/algorithms/calibrate/die_temperature.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"

using namespace gyrotc::calibrate;

namespace {

// dT_die/dt = (T_sensor - T_die) / lag by Heun's method in 1 ms steps, the
// sensor moving linearly between its readings.
std::vector<double> integrated(const std::vector<double>& time_s, const std::vector<double>& sensor_c, double lag_s) {
  std::vector<double> die{sensor_c.front()};
  double y = sensor_c.front();
  for (std::size_t i = 1; i < time_s.size(); ++i) {
    const double dt = time_s[i] - time_s[i - 1];
    const int steps = static_cast<int>(std::ceil(dt / 1e-3));
    const double h = dt / steps;
    for (int k = 0; k < steps; ++k) {
      auto u = [&](double f) { return sensor_c[i - 1] + (sensor_c[i] - sensor_c[i - 1]) * f; };
      const double k1 = (u(static_cast<double>(k) / steps) - y) / lag_s;
      const double k2 = (u(static_cast<double>(k + 1) / steps) - (y + h * k1)) / lag_s;
      y += 0.5 * h * (k1 + k2);
    }
    die.push_back(y);
  }
  return die;
}

}  // namespace

TEST_CASE("die temperature: on a steady ramp the die settles lag x rate behind the sensor",
          "[calibrate][die_temperature]") {
  std::vector<double> t, c;
  for (int i = 0; i <= 3000; ++i) {
    t.push_back(i);
    c.push_back(20.0 + 0.01 * i);  // 0.6 C/min
  }
  const std::vector<double> die = die_temperature_c(t, c, 120.0);
  CHECK(c.back() - die.back() == Approx(1.2).margin(1e-6));
  CHECK(die.front() == 20.0);
}

TEST_CASE("die temperature: follows the lag's equation through steps, turns and uneven readings",
          "[calibrate][die_temperature]") {
  std::vector<double> t, c;
  double time = 0.0;
  for (int i = 0; i < 400; ++i) {
    time += (i % 7 == 3) ? 2.5 : 0.75;  // readings late now and then
    t.push_back(time);
    // A ramp up, a step down, a sine: 1/16 C steps as a DS18B20 reads.
    const double truth = time < 100.0 ? 20.0 + 0.05 * time : (time < 160.0 ? 18.0 : 18.0 + 3.0 * std::sin(time / 30.0));
    c.push_back(gyrotc::test::ds18b20_steps_c(truth));
  }
  const std::vector<double> die = die_temperature_c(t, c, 40.0);
  const std::vector<double> expected = integrated(t, c, 40.0);
  double worst = 0.0;
  for (std::size_t i = 0; i < die.size(); ++i) worst = std::max(worst, std::fabs(die[i] - expected[i]));
  CHECK(worst < 1e-6);
  // The die lags: right after the step down it is still well above the sensor.
  const auto after_step = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), 101.0) - t.begin());
  CHECK(die[after_step] - c[after_step] > 2.5);
}

TEST_CASE("die temperature: a row without a reading is NaN and the lag carries on over the gap",
          "[calibrate][die_temperature]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> t{0.0, 1.0, 2.0, 3.0, 4.0};
  const std::vector<double> with_gap = die_temperature_c(t, std::vector<double>{nan, 20.0, nan, 30.0, 30.0}, 10.0);
  CHECK(std::isnan(with_gap[0]));
  CHECK(std::isnan(with_gap[2]));
  // From 20 C at 1 s to 30 C at 3 s: the same as the sensor read halfway at 2 s.
  const std::vector<double> whole = die_temperature_c(std::vector<double>{1.0, 2.0, 3.0, 4.0},
                                                      std::vector<double>{20.0, 25.0, 30.0, 30.0}, 10.0);
  CHECK(with_gap[3] == Approx(whole[2]).epsilon(1e-12));
  CHECK(with_gap[4] == Approx(whole[3]).epsilon(1e-12));
}

TEST_CASE("die temperature: no lag gives the readings themselves", "[calibrate][die_temperature]") {
  const std::vector<double> t{0.0, 1.0, 2.0};
  const std::vector<double> c{20.0, 25.0, 22.0};
  CHECK(die_temperature_c(t, c, 0.0) == c);
}

TEST_CASE("die temperature: mismatched spans, times that go back and an infinite lag are refused",
          "[calibrate][die_temperature]") {
  const std::vector<double> t{0.0, 2.0, 1.0};
  const std::vector<double> c{20.0, 21.0, 22.0};
  CHECK_THROWS_AS(die_temperature_c(t, c, 10.0), std::invalid_argument);
  CHECK_THROWS_AS(die_temperature_c(std::vector<double>{0.0}, c, 10.0), std::invalid_argument);
  CHECK_THROWS_AS(die_temperature_c(std::vector<double>{0.0, 1.0, 2.0}, c,
                                    std::numeric_limits<double>::infinity()),
                  std::invalid_argument);
}

TEST_CASE("die temperature, one reading at a time: follows the lag's equation as the Controller feeds it",
          "[calibrate][die_temperature]") {
  DieTemperature die;
  CHECK_FALSE(die.started());
  std::vector<double> t, c, streamed;
  double time = 0.0;
  for (int i = 0; i < 300; ++i) {
    time += (i % 5 == 2) ? 3.0 : 0.75;
    t.push_back(time);
    c.push_back(gyrotc::test::ds18b20_steps_c(25.0 + 6.0 * std::sin(time / 40.0)));
    die.update(t.back(), c.back(), 60.0);
    streamed.push_back(die.die_c());
  }
  CHECK(die.started());
  CHECK(streamed.front() == c.front());
  const std::vector<double> expected = integrated(t, c, 60.0);
  double worst = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) worst = std::max(worst, std::fabs(streamed[i] - expected[i]));
  CHECK(worst < 1e-6);
}

TEST_CASE("die temperature, one reading at a time: no lag is the reading, and a lag set later starts from it",
          "[calibrate][die_temperature]") {
  DieTemperature die;
  die.update(0.0, 20.0, 0.0);
  die.update(1.0, 30.0, 0.0);
  CHECK(die.die_c() == 30.0);
  // From 30 C, the sensor steady: the die stays; then a ramp of 0.1 C/s read
  // every second for 50 lags of 2 s: the die settles 0.2 C behind.
  die.update(2.0, 30.0, 2.0);
  CHECK(die.die_c() == 30.0);
  for (int i = 1; i <= 100; ++i) die.update(2.0 + i, 30.0 + 0.1 * i, 2.0);
  CHECK(die.die_c() == Approx(40.0 - 0.2).margin(1e-9));
}

TEST_CASE("die temperature, one reading at a time: a reading stamped before the last moves no time",
          "[calibrate][die_temperature]") {
  DieTemperature die;
  die.update(10.0, 20.0, 30.0);
  die.update(9.0, 40.0, 30.0);  // a late hand-over's stamp: no time passed, the die stays
  CHECK(die.die_c() == 20.0);
  die.update(11.0, 40.0, 30.0);
  // One second on from the reading at 10 s: as if the sensor stood at 40 C the whole second.
  CHECK(die.die_c() == Approx(40.0 - 20.0 * std::exp(-1.0 / 30.0)).epsilon(1e-12));
}
