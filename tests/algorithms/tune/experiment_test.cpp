// The identification experiment (tune/experiment.hpp) on a toy casing: a
// first-order lag with the TEC's heat, stepped every control period.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"

using namespace gyrotc;
using tune::ExperimentPhase;
using tune::IdentificationExperiment;

namespace {

struct Step {
  double time_s;
  double casing_c;
  double current_a;
  ExperimentPhase phase;
};

// Runs the experiment to its end on dT/dt = k I - (T - Ta) / tau, at 2 s
// periods; returns every period.
std::vector<Step> run(IdentificationExperiment& e, double ambient_c, double min_a = -1.0, double max_a = 1.0,
                      double k_per_a_s = 0.05) {
  std::vector<Step> out;
  double t = 0.0;
  double casing = ambient_c;
  for (;;) {
    control::TecProgramInput in;
    in.time_s = t;
    in.casing_c = test::ds18b20_steps_c(casing);
    in.ambient_c = ambient_c;
    in.setpoint_c = 55.0;
    in.min_a = min_a;
    in.max_a = max_a;
    const control::TecProgramOutput o = e.next(in);
    if (o.finished) break;
    out.push_back({t, casing, o.current_a, e.phase()});
    const double i = std::clamp(o.current_a, min_a, max_a);
    for (int s = 0; s < 20; ++s) casing += 0.1 * (k_per_a_s * i - (casing - ambient_c) / 3000.0);
    t += 2.0;
    if (t > 5.0 * 3600.0) break;
  }
  return out;
}

std::vector<ExperimentPhase> phases_in_order(const std::vector<Step>& steps) {
  std::vector<ExperimentPhase> phases;
  for (const auto& s : steps) {
    if (phases.empty() || phases.back() != s.phase) phases.push_back(s.phase);
  }
  return phases;
}

}  // namespace

TEST_CASE("the experiment runs rest, approach, relay, prbs, coast, cool and reheat, then ends, within 3 h") {
  IdentificationExperiment e;
  const std::vector<Step> steps = run(e, 16.0);
  const std::vector<ExperimentPhase> expected = {ExperimentPhase::rest,  ExperimentPhase::approach,
                                                 ExperimentPhase::relay, ExperimentPhase::prbs,
                                                 ExperimentPhase::coast, ExperimentPhase::cool,
                                                 ExperimentPhase::reheat};
  CHECK(phases_in_order(steps) == expected);
  CHECK(e.phase() == ExperimentPhase::done);
  CHECK(steps.back().time_s <= e.plan().max_duration_s());
  CHECK(e.plan().max_duration_s() <= 3.0 * 3600.0);
}

TEST_CASE("each phase drives the current its purpose needs") {
  IdentificationExperiment e;
  const std::vector<Step> steps = run(e, 16.0);
  double prbs_hi = -1e9, prbs_lo = 1e9;
  std::vector<double> relay_jumps;
  double last_relay = std::nan("");
  for (const auto& s : steps) {
    switch (s.phase) {
      case ExperimentPhase::rest: CHECK(s.current_a == 0.0); break;
      case ExperimentPhase::approach: CHECK(s.current_a == 1.0); break;  // towards the setpoint above
      case ExperimentPhase::relay:
        if (std::isfinite(last_relay) && s.current_a != last_relay) relay_jumps.push_back(std::fabs(s.current_a - last_relay));
        last_relay = s.current_a;
        CHECK(std::fabs(s.casing_c - 55.0) < 2.0);  // the relay holds the casing around the setpoint
        break;
      case ExperimentPhase::prbs:
        prbs_hi = std::max(prbs_hi, s.current_a);
        prbs_lo = std::min(prbs_lo, s.current_a);
        CHECK(std::fabs(s.casing_c - 55.0) < 3.0);  // the guard keeps it near
        break;
      case ExperimentPhase::coast: CHECK(s.current_a == 0.0); break;
      case ExperimentPhase::cool: CHECK(s.current_a == -1.0); break;
      case ExperimentPhase::reheat: CHECK(s.current_a == 1.0); break;
      case ExperimentPhase::done: break;
      case ExperimentPhase::wrong_way: FAIL("a correctly wired TEC's approach ended as wired the wrong way round"); break;
    }
  }
  // The relay switches between bias +/- half the range (the bias moves at
  // the switch that ends a cycle): jumps of about 1 A, many of them.
  REQUIRE(relay_jumps.size() >= 10);
  std::sort(relay_jumps.begin(), relay_jumps.end());
  CHECK(relay_jumps[relay_jumps.size() / 2] == Approx(1.0).margin(0.15));
  CHECK(prbs_hi - prbs_lo > 0.6);
}

TEST_CASE("every current the experiment asks for is within the limits it is given") {
  IdentificationExperiment e;
  for (const auto& s : run(e, 16.0, -0.4, 0.7)) {
    CHECK(s.current_a >= -0.4 - 1e-12);
    CHECK(s.current_a <= 0.7 + 1e-12);
  }
}

TEST_CASE("in a room above the setpoint the experiment approaches by cooling and turns the other phases round") {
  IdentificationExperiment e;
  const std::vector<Step> steps = run(e, 70.0, -1.0, 1.0, 0.08);
  bool approached = false;
  for (const auto& s : steps) {
    if (s.phase == ExperimentPhase::approach) {
      CHECK(s.current_a == -1.0);
      approached = true;
    }
    if (s.phase == ExperimentPhase::cool) CHECK(s.current_a == 1.0);    // away from the setpoint
    if (s.phase == ExperimentPhase::reheat) CHECK(s.current_a == -1.0);  // towards it again
  }
  CHECK(approached);
}

TEST_CASE("an unreachable setpoint times the approach out instead of heating for ever") {
  IdentificationExperiment e;
  // 0.2 A through a weak TEC holds the casing ~30 K above a 16 C room at most.
  const std::vector<Step> steps = run(e, 16.0, -0.2, 0.2, 0.05);
  double approach_s = 0.0;
  for (const auto& s : steps) approach_s += s.phase == ExperimentPhase::approach ? 2.0 : 0.0;
  CHECK(approach_s == Approx(e.plan().approach_timeout_s).margin(4.0));
  CHECK(steps.back().time_s <= e.plan().max_duration_s());
}

TEST_CASE("a TEC wired the wrong way round ends the experiment in its approach once the casing has moved 2 C away") {
  for (const double room_c : {16.0, 70.0}) {  // heating towards the setpoint, and cooling
    INFO("room " << room_c << " C");
    IdentificationExperiment e;
    const std::vector<Step> steps = run(e, room_c, -1.0, 1.0, -0.05);  // the current moves the casing the other way
    REQUIRE_FALSE(steps.empty());
    CHECK(e.phase() == ExperimentPhase::wrong_way);
    CHECK(steps.back().phase == ExperimentPhase::approach);
    CHECK(std::fabs(steps.back().casing_c - room_c) == Approx(2.0).margin(0.2));
    CHECK(steps.back().time_s < 120.0);
  }
}

TEST_CASE("an experiment plan that cannot work is rejected naming the field") {
  tune::ExperimentPlan plan;
  plan.relay_fraction = 1.5;
  CHECK_THROWS_WITH(IdentificationExperiment(plan), Catch::Contains("relay_fraction"));
}

TEST_CASE("a scaled experiment runs every phase in its fraction of the time, with a hold as much faster") {
  const tune::ExperimentPlan full;
  const tune::ExperimentPlan tenth = full.scaled(0.1);
  CHECK(tenth.max_duration_s() == Approx(0.1 * full.max_duration_s()));
  CHECK(tenth.prbs_bit_s == Approx(0.1 * full.prbs_bit_s));
  CHECK(tenth.hold_ki_a_per_c_s == Approx(10.0 * full.hold_ki_a_per_c_s));
  CHECK(tenth.hold_kp_a_per_c == full.hold_kp_a_per_c);
  CHECK(tenth.relay_fraction == full.relay_fraction);
  CHECK_THROWS_AS(full.scaled(0.0), std::invalid_argument);
  CHECK_THROWS_AS(full.scaled(1.5), std::invalid_argument);
}

TEST_CASE("a scaled experiment on a casing that many times faster passes through the same phases") {
  IdentificationExperiment e(tune::ExperimentPlan{}.scaled(0.1));
  const std::vector<Step> steps = run(e, 25.0, -1.0, 1.0, 0.5);  // the TEC's heat on a tenth of the capacity
  REQUIRE_FALSE(steps.empty());
  CHECK(phases_in_order(steps) ==
        std::vector<ExperimentPhase>{ExperimentPhase::rest, ExperimentPhase::approach, ExperimentPhase::relay,
                                     ExperimentPhase::prbs, ExperimentPhase::coast, ExperimentPhase::cool,
                                     ExperimentPhase::reheat});
  CHECK(steps.back().time_s <= tune::ExperimentPlan{}.scaled(0.1).max_duration_s());
}
