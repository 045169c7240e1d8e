// The self-calibration sweep (sweep_experiment.hpp) on a lumped casing with
// a Peltier-like gain, a loss to the ambient and a DS18B20's 1/16 C steps:
// what it asks of the stage and what the record gets.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/calibrate/sweep_experiment.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"

using namespace gyrotc::calibrate;
using gyrotc::control::TecProgramInput;

namespace {

struct Casing {
  double capacity_j_per_k = 300.0;
  double gain_w_per_a = 30.0;  // heat into the casing per ampere: 1 A holds 100 C from the ambient
  double loss_w_per_k = 0.3;
  double ambient_c = 20.0;
  double temp_c = 20.0;
};

// The gyro die inside the casing, which the sensor does not show: it follows
// the casing through a first-order lag, and the gyro reads a line at the
// die, with white noise on each period's mean and a first-order wander (the
// plant's own figures are not used: these are of the same class).
struct Die {
  double lag_s = 40.0;
  double slope_mv_per_c = 0.5;
  double drift_mv_per_s = 0.0;  // a bias that keeps moving whatever the die does
  double white_mv = 0.0;        // per 2 s mean
  double wander_mv = 0.0;
  double wander_tau_s = 100.0;
  std::uint64_t seed = 3;
};

struct Trace {
  std::vector<double> time_s;
  std::vector<double> casing_c;
  std::vector<double> die_c;
  std::vector<double> trend_dps;  // what the sweep shows after each period
  std::vector<SweepPhase> phase;
  bool finished = false;
};

// Without a die the programme gets no gyro output (NaN, as with no samples).
Trace run(SweepExperiment& sweep, Casing plant, double setpoint_c = 55.0, double limit_a = 1.0,
          std::optional<Die> die = std::nullopt) {
  Trace t;
  constexpr double kPeriodS = 2.0;  // the controller's PID period
  std::mt19937_64 rng(die ? die->seed : 0);
  std::normal_distribution<double> normal;
  double die_c = plant.temp_c;
  double wander_mv = 0.0;
  for (double time_s = 0.0; time_s < 8.0 * 3600.0; time_s += kPeriodS) {
    TecProgramInput in;
    in.time_s = time_s;
    in.casing_c = gyrotc::test::ds18b20_steps_c(plant.temp_c);
    in.ambient_c = gyrotc::test::ds18b20_steps_c(plant.ambient_c);
    in.setpoint_c = setpoint_c;
    in.min_a = -limit_a;
    in.max_a = limit_a;
    if (die) {
      const double a = std::exp(-kPeriodS / die->wander_tau_s);
      wander_mv = a * wander_mv + std::sqrt(1.0 - a * a) * die->wander_mv * normal(rng);
      in.gyro_mv = die->slope_mv_per_c * die_c + die->drift_mv_per_s * time_s + wander_mv + die->white_mv * normal(rng);
      in.gyro_scale_mv_per_dps = 8.774;
    }
    const auto out = sweep.next(in);
    t.time_s.push_back(time_s);
    t.casing_c.push_back(plant.temp_c);
    t.die_c.push_back(die_c);
    t.trend_dps.push_back(sweep.gyro_trend_dps());
    t.phase.push_back(sweep.phase());
    if (out.finished) {
      t.finished = true;
      break;
    }
    const double current_a = std::clamp(out.current_a, in.min_a, in.max_a);
    for (int k = 0; k < 20; ++k) {
      const double dt = kPeriodS / 20.0;
      plant.temp_c += dt * (plant.gain_w_per_a * current_a - plant.loss_w_per_k * (plant.temp_c - plant.ambient_c)) /
                      plant.capacity_j_per_k;
      if (die) die_c += dt * (plant.temp_c - die_c) / die->lag_s;
    }
  }
  return t;
}

// The row where a phase ends (its last row).
std::size_t end_of(const Trace& t, SweepPhase phase) {
  std::size_t last = 0;
  for (std::size_t i = 0; i < t.phase.size(); ++i) {
    if (t.phase[i] == phase) last = i;
  }
  return last;
}

std::size_t start_of(const Trace& t, SweepPhase phase) {
  for (std::size_t i = 0; i < t.phase.size(); ++i) {
    if (t.phase[i] == phase) return i;
  }
  return t.phase.size();
}

}  // namespace

TEST_CASE("the sweep's range runs from below the ambient to above the setpoint, never past the ceiling") {
  SweepPlan plan;
  const SweepRange r = plan.range(20.0, 55.0);
  CHECK(r.low_c == 8.0);
  CHECK(r.high_c == 67.0);
  plan.ceiling_c = 60.0;
  CHECK(plan.range(20.0, 55.0).high_c == 60.0);
  plan.low_c = -5.0;
  plan.high_c = 40.0;
  CHECK(plan.range(20.0, 55.0).low_c == -5.0);
  CHECK(plan.range(20.0, 55.0).high_c == 40.0);
}

TEST_CASE("a stage that reaches the range: down, dwell, up, dwell, back to the start, then the TEC off") {
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{});
  REQUIRE(t.finished);
  std::vector<SweepPhase> order;
  for (SweepPhase p : t.phase) {
    if (order.empty() || order.back() != p) order.push_back(p);
  }
  CHECK(order == std::vector{SweepPhase::rest, SweepPhase::down, SweepPhase::dwell_low, SweepPhase::up,
                             SweepPhase::dwell_high, SweepPhase::back, SweepPhase::done});
  CHECK(sweep.reached_low_c() == Approx(8.0).margin(0.5));  // the casing's overshoot at the turn
  CHECK(sweep.reached_high_c() == Approx(67.0).margin(0.5));
  const auto [lo, hi] = std::minmax_element(t.casing_c.begin(), t.casing_c.end());
  CHECK(*lo == Approx(8.0).margin(0.3));
  CHECK(*hi == Approx(67.0).margin(0.3));
  CHECK(t.casing_c.back() == Approx(20.0).margin(0.5));
  CHECK(t.time_s.back() <= sweep.plan().max_duration_s(sweep.range()));
  CHECK(t.time_s.back() <= 4.0 * 3600.0);
}

TEST_CASE("the casing never moves faster than the ramp asks, over the rate screen's minute") {
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{});
  double worst_c_per_min = 0.0;
  for (std::size_t i = 30; i < t.time_s.size(); ++i) {
    worst_c_per_min = std::max(worst_c_per_min, std::fabs(t.casing_c[i] - t.casing_c[i - 30]) / 1.0);
  }
  CHECK(worst_c_per_min <= 1.25 * sweep.plan().rate_c_per_min);
}

TEST_CASE("every temperature of the range is crossed once down and once up, at nearly the same rate") {
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{});
  // Time spent in each 1 C bin going down and going up (the dwells excluded).
  // Every 5 C, away from the ends and from the start at 20 C.
  for (double bin_c : {10.0, 15.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0}) {
    double down_s = 0.0;
    double up_s = 0.0;
    for (std::size_t i = 1; i < t.time_s.size(); ++i) {
      if (t.casing_c[i] < bin_c || t.casing_c[i] >= bin_c + 1.0) continue;
      if (t.phase[i] == SweepPhase::down || t.phase[i] == SweepPhase::back) down_s += 2.0;
      if (t.phase[i] == SweepPhase::up) up_s += 2.0;
    }
    INFO("bin " << bin_c << " C: " << down_s << " s down, " << up_s << " s up");
    CHECK(down_s == Approx(100.0).epsilon(0.3));
    CHECK(up_s == Approx(down_s).epsilon(0.2));
  }
}

TEST_CASE("a stage that cannot cool as far as asked ends the range where it stalls, and still finishes") {
  Casing weak;
  weak.gain_w_per_a = 2.0;  // 1 A holds 6.7 C from the ambient at most
  SweepExperiment sweep;
  const Trace t = run(sweep, weak);
  REQUIRE(t.finished);
  // It holds 13.3 .. 26.7 C at most, approached with tau = 1000 s: the
  // stall is called a quarter of the ramp's rate x tau (2.5 C) short of it.
  CHECK(sweep.reached_low_c() > 20.0 - 2.0 / 0.3);
  CHECK(sweep.reached_low_c() < 20.0 - 2.0 / 0.3 + 3.5);
  CHECK(sweep.reached_high_c() < 20.0 + 2.0 / 0.3);
  CHECK(sweep.reached_high_c() > 20.0 + 2.0 / 0.3 - 3.5);
  CHECK(t.time_s.back() <= sweep.plan().max_duration_s(sweep.range()));
}

TEST_CASE("a stage creeping towards its limit is taken as stalled when it falls behind, not hours later when it stops") {
  Casing slow;
  slow.loss_w_per_k = 0.1;  // tau 3000 s
  slow.gain_w_per_a = 3.0;  // 1 A holds 30 C from the ambient at most: 50 C, short of 67 C
  SweepExperiment sweep;
  const Trace t = run(sweep, slow);
  REQUIRE(t.finished);
  // Called a quarter of the ramp's rate x tau (7.5 C) short of the 50 C it creeps towards.
  CHECK(sweep.reached_high_c() < 50.0);
  CHECK(sweep.reached_high_c() > 50.0 - 7.5 - 1.0);
  CHECK(t.time_s.back() <= sweep.plan().max_duration_s(sweep.range()));
}

TEST_CASE("an end the casing lagged short of is reported where the casing was, not where the target was") {
  Casing weak;
  weak.gain_w_per_a = 2.0;
  SweepExperiment sweep;
  const Trace t = run(sweep, weak);
  const auto [lo, hi] = std::minmax_element(t.casing_c.begin(), t.casing_c.end());
  CHECK(sweep.reached_low_c() == Approx(*lo).margin(0.07));  // a DS18B20 step
  CHECK(sweep.reached_high_c() == Approx(*hi).margin(0.07));
}

TEST_CASE("an end is held until the gyro's output settles: a slow die the sensor does not show is waited for") {
  Die slow;
  slow.lag_s = 400.0;
  slow.white_mv = 0.1;
  slow.wander_mv = 0.088;  // 0.01 deg/s
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{}, 55.0, 1.0, slow);
  REQUIRE(t.finished);
  for (SweepPhase dwell : {SweepPhase::dwell_low, SweepPhase::dwell_high}) {
    const std::size_t start = start_of(t, dwell);
    const std::size_t end = end_of(t, dwell);
    const std::size_t after_fixed_dwell = start + static_cast<std::size_t>(sweep.plan().dwell_s / 2.0);
    INFO(to_string(dwell) << ": held " << t.time_s[end] - t.time_s[start] << " s; die " << t.die_c[end] << " C, casing "
                          << t.casing_c[end] << " C; after dwell_s the die was " << t.die_c[after_fixed_dwell] << " C");
    // dwell_s alone would have turned with the die 1.5 C away or more.
    CHECK(std::fabs(t.die_c[after_fixed_dwell] - t.casing_c[after_fixed_dwell]) > 1.5);
    CHECK(std::fabs(t.die_c[end] - t.casing_c[end]) < 0.75);
  }
  CHECK(sweep.dwell_low_s() > 2.0 * sweep.plan().dwell_s);
  CHECK(sweep.dwell_high_s() > 2.0 * sweep.plan().dwell_s);
  CHECK(sweep.settled_low());  // before dwell_max_s
  CHECK(sweep.settled_high());
}

TEST_CASE("in a dwell the sweep shows how far the gyro moved over the window: why the end is still held") {
  Die slow;
  slow.lag_s = 400.0;
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{}, 55.0, 1.0, slow);
  REQUIRE(t.finished);
  for (SweepPhase dwell : {SweepPhase::dwell_low, SweepPhase::dwell_high}) {
    const std::size_t start = start_of(t, dwell);
    const std::size_t turn = end_of(t, dwell) + 1;  // the period the dwell ended in
    const std::size_t after_fixed_dwell = start + static_cast<std::size_t>(sweep.plan().dwell_s / 2.0);
    INFO(to_string(dwell) << ": trend " << t.trend_dps[after_fixed_dwell] << " deg/s after dwell_s, "
                          << t.trend_dps[turn] << " at the turn");
    CHECK(std::isnan(t.trend_dps[start]));  // not judged before a window's worth
    CHECK(std::fabs(t.trend_dps[after_fixed_dwell]) > sweep.plan().settle_dps);
    CHECK(std::fabs(t.trend_dps[turn]) <= sweep.plan().settle_dps);
  }
}

TEST_CASE("a die that keeps up with the casing is held as long as the casing takes to settle, and judged settled") {
  // The casing overshoots a ramp's end and creeps back; the gyro follows it.
  // A die 20 s behind adds next to nothing to that wait.
  Die instant;
  instant.lag_s = 1.0;
  Die quick;
  quick.lag_s = 20.0;
  SweepExperiment follows_at_once;
  SweepExperiment follows_quickly;
  REQUIRE(run(follows_at_once, Casing{}, 55.0, 1.0, instant).finished);
  REQUIRE(run(follows_quickly, Casing{}, 55.0, 1.0, quick).finished);
  CHECK(follows_quickly.dwell_low_s() == Approx(follows_at_once.dwell_low_s()).margin(40.0));
  CHECK(follows_quickly.dwell_high_s() == Approx(follows_at_once.dwell_high_s()).margin(40.0));
  CHECK(follows_quickly.dwell_low_s() < 0.5 * follows_quickly.plan().dwell_max_s);
  CHECK(follows_quickly.settled_low());
  CHECK(follows_quickly.settled_high());
}

TEST_CASE("a gyro whose output never settles is held dwell_max_s, and not called settled") {
  Die drifting;
  drifting.drift_mv_per_s = 1e-3;  // 0.24 mV over the window: 0.027 deg/s
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{}, 55.0, 1.0, drifting);
  REQUIRE(t.finished);
  CHECK(sweep.dwell_low_s() == Approx(sweep.plan().dwell_max_s).margin(2.0));
  CHECK(sweep.dwell_high_s() == Approx(sweep.plan().dwell_max_s).margin(2.0));
  CHECK_FALSE(sweep.settled_low());
  CHECK(t.time_s.back() <= sweep.plan().max_duration_s(sweep.range()));
}

TEST_CASE("without the gyro's output the ends are held dwell_s, not called settled") {
  SweepExperiment sweep;
  const Trace t = run(sweep, Casing{});
  REQUIRE(t.finished);
  CHECK(sweep.dwell_low_s() == Approx(sweep.plan().dwell_s).margin(2.0));
  CHECK_FALSE(sweep.settled_low());
  CHECK_FALSE(sweep.settled_high());
}

TEST_CASE("a ceiling below the range's low end sweeps nothing and ends at once with the TEC off") {
  SweepPlan plan;
  plan.ceiling_c = 10.0;
  SweepExperiment sweep(plan);
  const Trace t = run(sweep, Casing{});
  CHECK(t.finished);
  CHECK(t.time_s.back() <= plan.rest_s + 2.0);
}

TEST_CASE("a bad sweep plan is refused naming the field") {
  SweepPlan p;
  p.rate_c_per_min = 0.0;
  CHECK_THROWS_WITH(validate(p), Catch::Contains("rate_c_per_min"));
  p = {};
  p.low_c = 30.0;
  p.high_c = 32.0;
  CHECK_THROWS_WITH(validate(p), Catch::Contains("high_c"));
  p = {};
  p.stall_s = -1.0;
  CHECK_THROWS_WITH(validate(p), Catch::Contains("stall_s"));
  p = {};
  p.dwell_max_s = p.dwell_s - 1.0;
  CHECK_THROWS_WITH(validate(p), Catch::Contains("dwell_max_s"));
  p = {};
  p.settle_dps = 0.0;
  CHECK_THROWS_WITH(validate(p), Catch::Contains("settle_dps"));
}

TEST_CASE("the time left it reports falls as the sweep goes and is within a tenth of what was left") {
  SweepExperiment sweep;
  Casing plant;
  std::vector<double> reported_s;
  std::vector<double> at_s;
  double end_s = 0.0;
  for (double time_s = 0.0; time_s < 8.0 * 3600.0; time_s += 2.0) {
    TecProgramInput in;
    in.time_s = time_s;
    in.casing_c = gyrotc::test::ds18b20_steps_c(plant.temp_c);
    in.ambient_c = plant.ambient_c;
    in.setpoint_c = 55.0;
    in.min_a = -1.0;
    in.max_a = 1.0;
    const auto out = sweep.next(in);
    if (out.finished) {
      end_s = time_s;
      break;
    }
    if (sweep.phase() != SweepPhase::rest && std::fmod(time_s, 600.0) == 0.0) {
      reported_s.push_back(sweep.remaining_s());
      at_s.push_back(time_s);
    }
    for (int k = 0; k < 20; ++k) {
      plant.temp_c += 0.1 * (plant.gain_w_per_a * out.current_a - plant.loss_w_per_k * (plant.temp_c - plant.ambient_c)) /
                      plant.capacity_j_per_k;
    }
  }
  REQUIRE(end_s > 0.0);
  REQUIRE(reported_s.size() > 10);
  for (std::size_t i = 0; i < reported_s.size(); ++i) {
    INFO("at " << at_s[i] << " s: reported " << reported_s[i] << " s, left " << end_s - at_s[i] << " s");
    CHECK(reported_s[i] == Approx(end_s - at_s[i]).margin(0.1 * (end_s - at_s[i]) + 120.0));
    if (i > 0) CHECK(reported_s[i] < reported_s[i - 1]);
  }
}
