// The thermal model `gyrotc tune` identifies (tune/thermal_model.hpp),
// checked against the plant simulator (model/plant.hpp: its own network, a
// die node, backward Euler, its own OPA548 stage) and against heat balances
// written out here from the physics.
#include <cmath>
#include <vector>

#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::model::Plant;
using gyrotc::model::PlantParams;
using namespace gyrotc::tune;
using gyrotc::model::stage_drive_v;

namespace {

// The tune model of a plant's physical parameters, per unit of the heat
// capacity the casing node carries (casing + die: the die follows the casing
// over minutes).
ThermalModel model_of(const PlantParams& p) {
  const double cc = p.casing_capacity_j_per_k + p.die_capacity_j_per_k;
  const double gp = p.tec_conductance_w_per_k + p.shell_casing_leak_w_per_k;
  const double gsa = p.shell_ambient_w_per_k;
  ThermalModel m;
  m.peltier_per_a_s = p.tec_seebeck_v_per_k / cc;
  m.joule_k_per_a2_s = p.tec_resistance_ohm / (2.0 * cc);
  m.loss_per_s = 1.0 / (1.0 / gsa + 1.0 / gp) / cc;
  m.shell_ratio = gsa / gp;
  m.shell_tau_s = p.shell_capacity_j_per_k / (gsa + gp);
  m.internal_k_per_s = p.internal_power_w / cc;
  m.dead_time_s = 0.0;
  m.sensor_lag_s = 0.0;
  m.rail_a = (p.supply_pos_v - p.rail_headroom_v) / p.tec_resistance_ohm;
  return m;
}

}  // namespace

namespace {

// The largest difference between the tune model's casing and the plant
// simulator's over a 1 A warm-up, a cooling step, a PRBS-like stretch and
// the TEC off; `limited` says whether the plant's stage clipped the current.
double largest_difference_c(const PlantParams& p, const ThermalModel& m, bool& limited) {
  Plant plant(p, 1);
  plant.set_ambient_c(16.0);
  plant.set_tec_enabled(true);
  std::vector<double> time_s;
  std::vector<double> command_a;
  for (int k = 0; k <= 4000; ++k) {
    time_s.push_back(k);
    double i = 1.0;
    if (k >= 900) i = -0.8;
    if (k >= 1200) i = (k / 37) % 2 == 0 ? 0.5 : -0.3;
    if (k >= 2800) i = 0.0;
    command_a.push_back(i);
  }
  const std::vector<double> ambient(time_s.size(), 16.0);
  std::vector<double> model_c(time_s.size());
  std::vector<double> scratch(time_s.size());
  simulate_sensor(m, {16.0, 16.0}, time_s, command_a, ambient, model_c, scratch);
  double worst = 0.0;
  limited = false;
  for (std::size_t k = 0; k < time_s.size(); ++k) {
    worst = std::max(worst, std::fabs(model_c[k] - plant.casing_c()));
    plant.set_tec_drive_v(stage_drive_v(p, command_a[k]));
    limited = limited || plant.tec_limited();
    plant.advance(1.0);
    plant.flush();
  }
  return worst;
}

}  // namespace

TEST_CASE("the tune model follows the plant simulator through heating, rail clipping, cooling and coasting") {
  PlantParams p;
  p.current_limit_a = 5.0;  // only the rails clip (1 A, once the casing is ~10 K above the shell)
  p.initial_temp_c = 16.0;
  bool clipped = false;
  const double worst = largest_difference_c(p, model_of(p), clipped);
  CHECK(clipped);  // the rail was exercised
  INFO("largest difference " << worst << " C over a 40 C warm-up");
  CHECK(worst < 0.05);
}

TEST_CASE("the tune model follows a plant whose stage limits the current below the commands, given that limit") {
  PlantParams p;
  p.current_limit_a = 0.6;  // the OPA548's ILIM below the 1 A and 0.8 A commanded
  p.initial_temp_c = 16.0;
  ThermalModel m = model_of(p);
  m.stage_limit_a = p.current_limit_a;
  bool limited = false;
  const double worst = largest_difference_c(p, m, limited);
  CHECK(limited);
  INFO("largest difference " << worst << " C");
  CHECK(worst < 0.05);
  // Without the limit the model heats and cools with the current commanded.
  m.stage_limit_a = ThermalModel{}.stage_limit_a;
  CHECK(largest_difference_c(p, m, limited) > 1.0);
}

TEST_CASE("at the steady state the model's heat balances close, written out in watts") {
  // Physical parameters chosen here (not the plant's defaults).
  const double cc = 200.0, cs = 40.0, s = 0.04, r = 10.0, gp = 0.12, gsa = 0.5, power = 0.2;
  ThermalModel m;
  m.peltier_per_a_s = s / cc;
  m.joule_k_per_a2_s = r / (2.0 * cc);
  m.loss_per_s = 1.0 / (1.0 / gsa + 1.0 / gp) / cc;
  m.shell_ratio = gsa / gp;
  m.shell_tau_s = cs / (gsa + gp);
  m.internal_k_per_s = power / cc;
  for (double i : {-0.6, 0.0, 0.35}) {
    const double ta = -10.0;
    const ThermalState x = steady_state(m, i, ta);
    const double tc_k = x.casing_c + 273.15;
    const double ts_k = x.shell_c + 273.15;
    // Into the casing: Peltier S I Tc, half the Joule heat, conduction from the shell, the electronics.
    const double casing_w = s * i * tc_k + 0.5 * i * i * r + gp * (x.shell_c - x.casing_c) + power;
    // Into the shell: Peltier -S I Ts, the other half, conduction from the casing and from the ambient.
    const double shell_w = -s * i * ts_k + 0.5 * i * i * r + gp * (x.casing_c - x.shell_c) + gsa * (ta - x.shell_c);
    CHECK(casing_w == Approx(0.0).margin(1e-9));
    CHECK(shell_w == Approx(0.0).margin(1e-9));
  }
}

TEST_CASE("the holding current holds the setpoint in steady state, and is NaN where the stage cannot") {
  const ThermalModel m = model_of(PlantParams{});
  for (double ta : {-30.0, 0.0, 16.0, 45.0}) {
    const double i = holding_current_a(m, 55.0, ta, 1.0);
    REQUIRE(std::isfinite(i));
    CHECK(steady_state(m, i, ta).casing_c == Approx(55.0).margin(1e-6));
  }
  // Colder ambient, more heat.
  CHECK(holding_current_a(m, 55.0, -20.0, 1.0) > holding_current_a(m, 55.0, 35.0, 1.0));
  // A stage that can give only 0.1 A does not hold 55 C at -20 C.
  CHECK(std::isnan(holding_current_a(m, 55.0, -20.0, 0.1)));
  // Nor does one whose rails stop at 0.2 A.
  ThermalModel weak = m;
  weak.rail_a = 0.2;
  CHECK(std::isnan(holding_current_a(weak, 55.0, -20.0, 1.0)));
  // Nor one whose own current limit is 0.1 A.
  ThermalModel limited = m;
  limited.stage_limit_a = 0.1;
  CHECK(std::isnan(holding_current_a(limited, 55.0, -20.0, 1.0)));
}

TEST_CASE("one long step and many short ones agree (the trapezoidal network is sub-stepped)") {
  const ThermalModel m = model_of(PlantParams{});
  const ThermalState start{20.0, 18.0};
  ThermalState fine = start;
  for (int k = 0; k < 6000; ++k) fine = step(m, fine, 0.4, 0.0, 0.01);
  const ThermalState coarse = step(m, start, 0.4, 0.0, 60.0);
  CHECK(coarse.casing_c == Approx(fine.casing_c).margin(2e-3));
  CHECK(coarse.shell_c == Approx(fine.shell_c).margin(2e-3));
}

TEST_CASE("the sensor sees the casing late by the dead time and smoothed by the lag") {
  ThermalModel m = model_of(PlantParams{});
  std::vector<double> t, cmd, amb;
  for (int k = 0; k <= 600; ++k) {
    t.push_back(k);
    cmd.push_back(k >= 100 ? 1.0 : 0.0);
    amb.push_back(16.0);
  }
  std::vector<double> plain(t.size()), delayed(t.size()), lagged(t.size()), scratch(t.size());
  simulate_sensor(m, {16.0, 16.0}, t, cmd, amb, plain, scratch);
  m.dead_time_s = 5.0;
  simulate_sensor(m, {16.0, 16.0}, t, cmd, amb, delayed, scratch);
  for (std::size_t k = 10; k < t.size(); ++k) CHECK(delayed[k] == Approx(plain[k - 5]).margin(1e-9));
  m.dead_time_s = 0.0;
  m.sensor_lag_s = 30.0;
  simulate_sensor(m, {16.0, 16.0}, t, cmd, amb, lagged, scratch);
  // Under a steady ramp a first-order lag trails by its time constant.
  const double slope = (plain[500] - plain[490]) / 10.0;
  CHECK(plain[500] - lagged[500] == Approx(slope * 30.0).epsilon(0.05));
}

TEST_CASE("a sensor with a share of the ambient settles between the casing and the room, and sees the room through its lag") {
  ThermalModel m = model_of(PlantParams{});
  m.dead_time_s = 0.0;
  m.sensor_lag_s = 30.0;
  m.sensor_ambient_share = 0.05;
  // The TEC off, the room stepping from 16 C to 26 C at 100 s.
  std::vector<double> t, cmd, amb;
  for (int k = 0; k <= 400; ++k) {
    t.push_back(k);
    cmd.push_back(0.0);
    amb.push_back(k >= 100 ? 26.0 : 16.0);
  }
  std::vector<double> seen(t.size()), scratch(t.size());
  simulate_sensor(m, {40.0, 20.0}, t, cmd, amb, seen, scratch);
  // At the start the reading is the casing's 40 C, 5 % of the way to the room.
  CHECK(seen[0] == Approx(0.95 * 40.0 + 0.05 * 16.0).margin(1e-9));
  // The room's step reaches the reading through the 30 s lag alone, long
  // before the shell passes it on: 5 % of 10 K, 63 % of it after one lag.
  std::vector<double> still(t.size());
  std::vector<double> still_amb(t.size(), 16.0);
  simulate_sensor(m, {40.0, 20.0}, t, cmd, still_amb, still, scratch);
  CHECK(seen[130] - still[130] == Approx(0.05 * 10.0 * (1.0 - std::exp(-1.0))).epsilon(0.05));
  // Without the share the same step has hardly reached the reading by then.
  m.sensor_ambient_share = 0.0;
  simulate_sensor(m, {40.0, 20.0}, t, cmd, amb, seen, scratch);
  simulate_sensor(m, {40.0, 20.0}, t, cmd, still_amb, still, scratch);
  CHECK(seen[130] - still[130] < 0.02);
  m.sensor_ambient_share = 0.05;
  // The current that holds the reading at 55 C holds the casing above it.
  const double i = holding_current_a(m, 55.0, 16.0, 1.0);
  REQUIRE(std::isfinite(i));
  CHECK(m.steady_reading_c(steady_state(m, i, 16.0).casing_c, 16.0) == Approx(55.0).margin(1e-6));
}
