#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::app;

namespace {

const gyrotc::fit::BiasModel& calibration() {
  static const gyrotc::fit::BiasModel model = gyrotc::fit::BiasModel::paper_reference();
  return model;
}

SimulationResult short_run(std::uint64_t seed, ControllerMode mode = ControllerMode::paper) {
  SimulationSetup setup;
  setup.controller = controller_preset(mode, setup.plant);
  setup.calibration = &calibration();
  setup.sample_rate_hz = 50.0;
  setup.seed = seed;
  const gyrotc::model::ChamberProfile profile({{"hold", 0.0, 300.0, 16.0, 16.0}});
  return run_simulation(setup, profile);
}

}  // namespace

TEST_CASE("lockstep runs are deterministic for a seed") {
  const auto a = short_run(5);
  const auto b = short_run(5);
  const auto c = short_run(6);
  REQUIRE(a.rows.size() == b.rows.size());
  bool same = true;
  bool differs = false;
  for (std::size_t i = 0; i < a.rows.size(); ++i) {
    same = same && a.rows[i].gyro_mv == b.rows[i].gyro_mv && a.rows[i].casing_c == b.rows[i].casing_c &&
           a.rows[i].tec_a == b.rows[i].tec_a;
    differs = differs || a.rows[i].gyro_mv != c.rows[i].gyro_mv;
  }
  CHECK(same);
  CHECK(differs);
}

TEST_CASE("the ambient sensor converts before every 10th casing conversion, which makes that sensor cycle 1.5 s") {
  SimulationSetup setup;
  setup.controller = controller_preset(ControllerMode::tuned, setup.plant);
  setup.calibration = &calibration();
  setup.sample_rate_hz = 50.0;
  const gyrotc::model::ChamberProfile profile({{"hold", 0.0, 1000.0, 16.0, 16.0}});
  const auto r = run_simulation(setup, profile);
  // Ten casing conversions every 10.5 s: nine 1 s cycles and one of 1.5 s
  // (750 ms ambient + 750 ms casing), the schedule the real-time runner keeps.
  CHECK(r.counters.readings == Approx(1000.0 / 1.05).margin(3.0));
  CHECK(r.counters.ambient_readings * kAmbientEveryReadings == Approx(r.counters.readings).margin(10.0));
}

TEST_CASE("with the controller off the TEC stays off and the casing follows the ambient") {
  const auto r = short_run(1, ControllerMode::off);
  for (const auto& row : r.rows) {
    CHECK(row.tec_a == 0.0);
    CHECK((row.flags & kFlagTecOff) != 0);
  }
  CHECK(r.rows.back().casing_c == Approx(16.0).margin(0.5));
}

TEST_CASE("the runner exposes the board for fault injection and reports the reaction") {
  SimulationSetup setup;
  setup.controller = controller_preset(ControllerMode::paper, setup.plant);
  gyrotc::hal::SimBoardOptions options;
  options.adc.fclk_hz = 50.0 * 384.0;
  options.tec_current_limit_a = setup.plant.current_limit_a;
  gyrotc::model::PlantParams plant = setup.plant;
  gyrotc::hal::SimBoard board(plant, 1, options);
  const gyrotc::fit::Compensator compensator(calibration());
  Controller controller(setup.controller, compensator);
  const gyrotc::model::ChamberProfile profile({{"hold", 0.0, 600.0, 16.0, 16.0}});
  LockstepRunner runner(board, controller, profile);
  std::vector<TecCommand> commands;
  runner.on_pid_tick([&](double, const TecCommand& c) { commands.push_back(c); });
  runner.run_until(60.0);
  REQUIRE_FALSE(commands.empty());
  CHECK(commands.back().enable);
  CHECK(board.plant().tec_current_a() > 0.0);
  runner.board().inject_opa548_thermal_shutdown(true);
  runner.run_until(64.0);  // one PID period later
  CHECK_FALSE(commands.back().enable);
  CHECK((commands.back().flags & kFlagOpa548Thermal) != 0);
  CHECK(board.plant().tec_current_a() == 0.0);
  runner.board().inject_opa548_thermal_shutdown(false);
  runner.run_until(100.0);  // inside the cool-down: still off
  CHECK_FALSE(commands.back().enable);
  runner.run_until(140.0);  // after it: retried and running again
  CHECK(commands.back().enable);
  CHECK(board.plant().tec_current_a() > 0.0);
}

TEST_CASE("a plant description round-trips through its TOML file, effects included") {
  gyrotc::model::PlantParams p;
  p.casing_capacity_j_per_k = 123.5;
  p.dac_bits = 14;
  p.effects.thermal_lag = gyrotc::model::ThermalLagEffect{42.0};
  p.effects.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{3.25};
  const auto q = parse_plant(format_plant(p), "round-trip.toml");
  CHECK(q.casing_capacity_j_per_k == 123.5);
  CHECK(q.dac_bits == 14);
  REQUIRE(q.effects.thermal_lag);
  CHECK(q.effects.thermal_lag->tau_s == 42.0);
  REQUIRE(q.effects.tec_joule_heating);
  CHECK(q.effects.tec_joule_heating->r_ohm == 3.25);
  CHECK_FALSE(q.effects.warm_up);
}

TEST_CASE("a plant file with an unknown key or a bad value names the line and the key") {
  CHECK_THROWS_WITH(parse_plant("[thermal]\ncasing_capacity_j_per_k = 1.0\nbogus = 2\n", "p.toml"),
                    Catch::Contains("p.toml:3") && Catch::Contains("thermal.bogus"));
  CHECK_THROWS_WITH(parse_plant("[tec]\nresistance_ohm = \"12\"\n", "p.toml"),
                    Catch::Contains("p.toml:2") && Catch::Contains("tec.resistance_ohm"));
  CHECK_THROWS_WITH(parse_plant("[tec]\nresistance_ohm = -1.0\n", "p.toml"),
                    Catch::Contains("resistance_ohm"));
  CHECK_THROWS_WITH(parse_plant("[effects.nonsense]\nx = 1.0\n", "p.toml"),
                    Catch::Contains("effects.nonsense"));
}

namespace {

// A plant whose zero-rate output is the line 40 + slope x T at the die (2
// points: the natural spline is the line), with a 3 mV offset of its own,
// held at two ambients with the TEC off; a calibration of that line and
// offset, plus error_mv, used at the casing DS18B20 (which reads
// sensor_offset_c high).
SimulationResult holds_with_line_calibration(double slope_mv_per_c, double error_mv, double sensor_offset_c) {
  gyrotc::fit::Polynomial line;
  line.coefficients_mv = {40.0 + 3.0 + error_mv, slope_mv_per_c};
  line.t_min_c = -40.0;
  line.t_max_c = 80.0;
  const gyrotc::fit::BiasModel model = gyrotc::fit::BiasModel::polynomial(line);
  SimulationSetup setup;
  setup.plant.zero_bias = gyrotc::model::ZeroBiasCurve({-40.0, 80.0}, {40.0 - 40.0 * slope_mv_per_c, 40.0 + 80.0 * slope_mv_per_c});
  setup.plant.zero_rate_offset_mv = 3.0;
  setup.plant.ds18b20_offset_c = sensor_offset_c;
  setup.controller = controller_preset(ControllerMode::off, setup.plant);
  setup.calibration = &model;
  setup.sample_rate_hz = 20.0;
  setup.seed = 3;
  const gyrotc::model::ChamberProfile profile(
      {{"h1", 0.0, 1800.0, 16.0, 16.0}, {"r", 1800.0, 2400.0, 16.0, 30.0}, {"h2", 2400.0, 4200.0, 30.0, 30.0}});
  return run_simulation(setup, profile);
}

}  // namespace

TEST_CASE("a simulation's calibration error is the compensated holds without the gyro's noise") {
  // A flat curve: the reading's steps do not matter.
  const auto exact = holds_with_line_calibration(0.0, 0.0, 0.0);
  CHECK(exact.summary.bias_compensated_max_abs_dps > 1e-4);  // the gyro's noise is there
  CHECK(exact.summary.calibration_error_max_abs_dps < 1e-9);  // and taken out
  // A calibration 0.8774 mV high takes 0.1 deg/s too much off the rate.
  const auto off = holds_with_line_calibration(0.0, 0.8774, 0.0);
  CHECK(off.summary.calibration_error_max_abs_dps == Approx(0.1).epsilon(1e-9));
  std::size_t holds = 0;
  for (const auto& s : off.summary.segments) {
    if (!s.has_bias) continue;
    ++holds;
    CHECK(s.calibration_error_dps == Approx(-0.1).epsilon(1e-9));
  }
  CHECK(holds == 2);
}

TEST_CASE("a simulation's calibration error is judged where the Controller compensated: the sensor's reading") {
  // The exact line, read by a DS18B20 0.5 C high: over each hold's second
  // half, the curve at the die less the calibration at the reading, about
  // 0.5 C x 0.5 mV/C = 0.0285 deg/s too much (at the die it would be 0).
  const auto r = holds_with_line_calibration(0.5, 0.0, 0.5);
  const auto& segments = r.summary.segments;
  std::size_t holds = 0;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    if (!segments[i].has_bias) continue;
    ++holds;
    const double from_s = i == 0 ? 900.0 : 3300.0;  // the second halves of h1 and h2
    const double to_s = i == 0 ? 1800.0 : 4200.0;
    double at_reading = 0.0;
    double n = 0.0;
    for (const auto& row : r.rows) {
      if (row.time_s < from_s || row.time_s > to_s) continue;
      at_reading += (0.5 * row.die_c - 0.5 * row.sensor_c) / 8.774;
      n += 1.0;
    }
    CHECK(segments[i].calibration_error_dps == Approx(at_reading / n).margin(5e-4));
    // The die trails the casing a little in these holds; the reading has 1/16 C steps.
    CHECK(segments[i].calibration_error_dps == Approx(-0.25 / 8.774).margin(0.01));
  }
  CHECK(holds == 2);
}
