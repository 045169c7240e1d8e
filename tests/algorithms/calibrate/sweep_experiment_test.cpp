// The self-calibration sweep (sweep_experiment.hpp) on a lumped casing with
// a Peltier-like gain, a loss to the ambient and a DS18B20's 1/16 C steps:
// what it asks of the stage and what the record gets.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/calibrate/sweep_experiment.hpp"
#include "gyrotc_catch.hpp"

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

struct Trace {
  std::vector<double> time_s;
  std::vector<double> casing_c;
  std::vector<SweepPhase> phase;
  bool finished = false;
};

double quantised(double c) { return std::round(c * 16.0) / 16.0; }

Trace run(SweepExperiment& sweep, Casing plant, double setpoint_c = 55.0, double limit_a = 1.0) {
  Trace t;
  constexpr double kPeriodS = 2.0;  // the controller's PID period
  for (double time_s = 0.0; time_s < 8.0 * 3600.0; time_s += kPeriodS) {
    TecProgramInput in;
    in.time_s = time_s;
    in.casing_c = quantised(plant.temp_c);
    in.ambient_c = quantised(plant.ambient_c);
    in.setpoint_c = setpoint_c;
    in.min_a = -limit_a;
    in.max_a = limit_a;
    const auto out = sweep.next(in);
    t.time_s.push_back(time_s);
    t.casing_c.push_back(plant.temp_c);
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
    }
  }
  return t;
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
    in.casing_c = quantised(plant.temp_c);
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
