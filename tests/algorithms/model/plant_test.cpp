#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/model/gyro_bias_curve.hpp"
#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::model::Plant;
using gyrotc::model::PlantParams;
using gyrotc::model::stage_drive_v;

namespace {

// A plant that reaches steady state quickly in step count: coarse steps are
// fine for a backward-Euler network at steady state.
PlantParams coarse(double step_s = 5.0) {
  PlantParams p;
  p.max_thermal_step_s = step_s;
  p.initial_temp_c = 16.0;
  return p;
}

void run(Plant& plant, double seconds) {
  plant.advance(seconds);
  plant.flush();
}

}  // namespace

TEST_CASE("with the TEC off and no internal power the plant settles at the ambient temperature") {
  PlantParams p = coarse();
  p.internal_power_w = 0.0;
  Plant plant(p, 1);
  plant.set_ambient_c(30.0);
  run(plant, 200'000.0);
  CHECK(plant.shell_c() == Approx(30.0).margin(1e-6));
  CHECK(plant.casing_c() == Approx(30.0).margin(1e-6));
  CHECK(plant.die_c() == Approx(30.0).margin(1e-6));
}

TEST_CASE("at steady state the internal power flows out through the shell and its insulation") {
  // Energy conservation, with the conductances of the parameters (not the
  // model's series formula): P = G_shell-ambient (T_shell - T_amb) = G_TEC+leak (T_casing - T_shell).
  PlantParams p = coarse();
  p.internal_power_w = 0.5;
  Plant plant(p, 1);
  plant.set_ambient_c(-10.0);
  run(plant, 300'000.0);
  const double through_shell_w = p.shell_ambient_w_per_k * (plant.shell_c() - plant.ambient_c());
  const double through_tec_w =
      (p.tec_conductance_w_per_k + p.shell_casing_leak_w_per_k) * (plant.casing_c() - plant.shell_c());
  CHECK(through_shell_w == Approx(0.5).epsilon(1e-6));
  CHECK(through_tec_w == Approx(0.5).epsilon(1e-6));
  CHECK(plant.die_c() == Approx(plant.casing_c()).margin(1e-6));  // no power in the die
}

TEST_CASE("positive TEC current heats the casing and negative current cools it") {
  PlantParams p;
  p.internal_power_w = 0.0;
  p.initial_temp_c = 20.0;
  Plant heating(p, 1);
  Plant cooling(p, 1);
  heating.set_ambient_c(20.0);
  cooling.set_ambient_c(20.0);
  heating.set_tec_enabled(true);
  cooling.set_tec_enabled(true);
  heating.set_tec_drive_v(stage_drive_v(p, 0.5));
  cooling.set_tec_drive_v(stage_drive_v(p, -0.5));
  run(heating, 600.0);
  run(cooling, 600.0);
  CHECK(heating.tec_current_a() == Approx(0.5).margin(1e-3));
  CHECK(cooling.tec_current_a() == Approx(-0.5).margin(1e-3));
  CHECK(heating.casing_c() > 25.0);
  CHECK(heating.shell_c() < 20.0);  // the TEC pumps heat out of the shell
  CHECK(cooling.casing_c() < 17.0);
}

TEST_CASE("the TEC stage maps mid-scale to 0 A, limits the current and is off when disabled") {
  PlantParams p;
  Plant plant(p, 1);
  plant.set_tec_drive_v(0.5 * p.dac_vref_v);
  plant.set_tec_enabled(true);
  CHECK(plant.tec_current_a() == 0.0);
  plant.set_tec_drive_v(p.dac_vref_v);  // far above the limit
  CHECK(plant.tec_current_a() == Approx(p.current_limit_a));
  CHECK(plant.tec_limited());
  plant.set_tec_enabled(false);
  CHECK(plant.tec_current_a() == 0.0);
}

TEST_CASE("the electrical power V I is the heat the TEC adds to the network (first law, every step)") {
  // Over one thermal step the heat stored in shell, casing and die grows by
  // what the TEC's terminals take (V I), the electronics add and the shell
  // loses to the ambient. Backward Euler makes this hold exactly for the
  // step's end state: a wrong voltage (the Seebeck term) or a Peltier or
  // Joule term on the wrong side breaks it.
  PlantParams p;
  p.initial_temp_c = 20.0;
  for (double current_a : {0.8, -0.6}) {
    Plant plant(p, 1);
    plant.set_ambient_c(5.0);
    plant.set_tec_enabled(true);
    plant.set_tec_drive_v(stage_drive_v(p, current_a));
    run(plant, 300.0);  // a temperature difference across the module
    const double h = p.max_thermal_step_s;
    const double shell0 = plant.shell_c(), casing0 = plant.casing_c(), die0 = plant.die_c();
    run(plant, h);
    const double stored_w = (p.shell_capacity_j_per_k * (plant.shell_c() - shell0) +
                             p.casing_capacity_j_per_k * (plant.casing_c() - casing0) +
                             p.die_capacity_j_per_k * (plant.die_c() - die0)) /
                            h;
    const double electrical_w = plant.tec_voltage_v() * plant.tec_current_a();
    const double lost_w = p.shell_ambient_w_per_k * (plant.shell_c() - plant.ambient_c());
    CHECK(stored_w == Approx(electrical_w + p.internal_power_w - lost_w).margin(1e-6));
    CHECK(std::fabs(plant.casing_c() - plant.shell_c()) > 5.0);  // the Seebeck voltage mattered
  }
}

TEST_CASE("the TEC voltage stays inside the OPA548's rails: the rails, not the current limit, clip") {
  PlantParams p;
  p.current_limit_a = 5.0;  // let the rails be the limit
  Plant plant(p, 1);
  plant.set_tec_enabled(true);
  plant.set_tec_drive_v(p.dac_vref_v);
  run(plant, 10.0);
  CHECK(plant.tec_voltage_v() <= p.supply_pos_v - p.rail_headroom_v + 0.05);
  CHECK(plant.tec_current_a() < 5.0);
  CHECK(plant.tec_limited());
}

TEST_CASE("the backward-Euler network is stable at the largest step, even with a tiny die") {
  PlantParams stiff = coarse(100.0);   // the largest step anyone would use
  stiff.die_capacity_j_per_k = 1e-4;   // tau_die = 2.5 ms
  PlantParams fine = stiff;
  fine.max_thermal_step_s = 0.1;       // the simulator's default step
  Plant a(stiff, 1);
  Plant b(fine, 1);
  for (Plant* plant : {&a, &b}) {
    plant->set_ambient_c(-30.0);
    plant->set_tec_enabled(true);
    plant->set_tec_drive_v(stage_drive_v(stiff, 0.4));
  }
  double previous_die_c = a.die_c();
  for (int k = 0; k < 200; ++k) {  // 20 000 s
    run(a, 100.0);
    REQUIRE(std::isfinite(a.die_c()));
    CHECK(std::fabs(a.die_c() - a.casing_c()) < 0.5);  // the die follows the casing, no ringing
    previous_die_c = a.die_c();
  }
  run(b, 20'000.0);
  CHECK(previous_die_c == Approx(b.die_c()).margin(0.05));
  CHECK(a.casing_c() == Approx(b.casing_c()).margin(0.05));
}

TEST_CASE("time given in small pieces reaches the same state as one large advance") {
  PlantParams p;
  Plant pieces(p, 1);
  Plant whole(p, 1);
  for (Plant* plant : {&pieces, &whole}) {
    plant->set_ambient_c(0.0);
    plant->set_tec_enabled(true);
    plant->set_tec_drive_v(stage_drive_v(p, 0.3));
  }
  for (int k = 0; k < 100'000; ++k) pieces.advance(1e-3);
  pieces.flush();
  run(whole, 100.0);
  CHECK(pieces.time_s() == Approx(100.0));
  CHECK(pieces.casing_c() == Approx(whole.casing_c()).margin(1e-3));
}

TEST_CASE("gyro samples are deterministic for a seed and differ between seeds") {
  PlantParams p;
  Plant a(p, 42);
  Plant b(p, 42);
  Plant c(p, 43);
  bool all_equal = true;
  bool any_different = false;
  for (int k = 0; k < 5000; ++k) {
    a.advance(1e-3);
    b.advance(1e-3);
    c.advance(1e-3);
    const double va = a.gyro_mv(1e-3);
    all_equal = all_equal && va == b.gyro_mv(1e-3);
    any_different = any_different || va != c.gyro_mv(1e-3);
  }
  CHECK(all_equal);
  CHECK(any_different);
}

TEST_CASE("the zero-rate output follows seed Table 2 at the die temperature") {
  PlantParams p;
  p.bias_instability_dps = 0.0;
  p.initial_temp_c = 25.0;
  Plant plant(p, 7);
  CHECK(plant.gyro_bias_mv() == Approx(79.9));  // Table 2 at 25 C
  const int n = 20'000;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) sum += plant.gyro_mv(1e-3);
  const double mean = sum / n;
  // 1 deg/sqrt(h) at 1 kHz is ~4.6 mV rms a sample (the Allan test below
  // checks that level): the mean of 20 000 is within 5 standard errors, 0.17 mV.
  CHECK(mean == Approx(79.9).margin(0.17));
  plant.set_rate_dps(10.0);
  double with_rate = 0.0;
  for (int k = 0; k < n; ++k) with_rate += plant.gyro_mv(1e-3);
  CHECK(with_rate / n - mean == Approx(10.0 * p.scale_mv_per_dps).margin(0.24));
}

TEST_CASE("the gyro's white noise reads back as its angle random walk in an Allan deviation (IEEE 952)") {
  // N (deg/sqrt(s)) is the Allan deviation's slope -1/2 line at 1 s; ARW in
  // deg/sqrt(h) is 60 N. Read from 200 s at 1 kHz by the stats module, not by
  // the plant's own sigma formula.
  PlantParams p;
  p.bias_instability_dps = 0.0;
  p.arw_deg_per_sqrt_h = 2.5;
  p.initial_temp_c = 25.0;
  Plant plant(p, 11);
  std::vector<double> rate_dps;
  rate_dps.reserve(200'000);
  for (int k = 0; k < 200'000; ++k) rate_dps.push_back(plant.gyro_mv(1e-3) / p.scale_mv_per_dps);
  const gyrotc::stats::AllanResult allan = gyrotc::stats::allan_deviation(rate_dps, 1000.0);
  const gyrotc::stats::TermEstimate& n = allan.fit.term(gyrotc::stats::NoiseTerm::angle_random_walk);
  REQUIRE(n.included);
  CHECK(60.0 * n.value == Approx(2.5).epsilon(0.05));
}

TEST_CASE("the Table 2 curve passes through every measured point and is continuous") {
  for (std::size_t i = 0; i < gyrotc::model::kTable2GyroMv.size(); ++i) {
    const double t = gyrotc::model::kTable2FirstC + 5.0 * static_cast<double>(i);
    CHECK(gyrotc::model::table2_bias_mv(t) == Approx(gyrotc::model::kTable2GyroMv[i]).margin(1e-9));
    CHECK(gyrotc::model::table2_bias_mv(t + 1e-7) == Approx(gyrotc::model::kTable2GyroMv[i]).margin(1e-4));
  }
  // Seed Table 1 (drive mode): 2471.60 Hz and Q 9886 at 20 C.
  CHECK(gyrotc::model::table1_drive_frequency_hz(20.0) == Approx(2471.60));
  CHECK(gyrotc::model::table1_drive_q(20.0) == Approx(9886.0));
}

TEST_CASE("a zero-bias curve is the natural cubic spline through its points, on an uneven grid too") {
  using gyrotc::model::ZeroBiasCurve;
  // By hand: through (0,0), (1,1), (3,0), M1 = 6 (-1/2 - 1) / (2 (1 + 2)) = -1.5,
  // S(0.5) = M1 0.5^3 / 6 + (1 - M1 / 6) 0.5 = 0.59375.
  const ZeroBiasCurve c({0.0, 1.0, 3.0}, {0.0, 1.0, 0.0});
  CHECK(c.bias_mv(0.5) == Approx(0.59375).margin(1e-12));
  CHECK(c.bias_mv(1.0) == Approx(1.0).margin(1e-12));
  CHECK(c.bias_mv(3.0) == Approx(0.0).margin(1e-12));
  // Outside its points it runs on along the end tangent: a straight line.
  CHECK(c.bias_mv(5.0) - c.bias_mv(4.0) == Approx(c.bias_mv(4.0) - c.bias_mv(3.0)).margin(1e-9));
  // Two points are a straight line.
  CHECK(ZeroBiasCurve({10.0, 20.0}, {1.0, 3.0}).bias_mv(12.5) == Approx(1.5).margin(1e-12));
}

TEST_CASE("a zero-bias curve refuses lists that are not a curve, naming what is wrong") {
  using gyrotc::model::ZeroBiasCurve;
  CHECK_THROWS_WITH(ZeroBiasCurve({0.0, 1.0}, {0.0}), Catch::Contains("2 temperatures but 1 outputs"));
  CHECK_THROWS_WITH(ZeroBiasCurve({0.0}, {0.0}), Catch::Contains("at least 2 points"));
  CHECK_THROWS_WITH(ZeroBiasCurve({0.0, 2.0, 1.0}, {0.0, 1.0, 2.0}), Catch::Contains("temperature 3 does not rise"));
  CHECK_THROWS_WITH(ZeroBiasCurve({0.0, 1.0}, {0.0, std::nan("")}), Catch::Contains("point 2 is not a finite"));
}

TEST_CASE("the plant's gyro follows the plant's zero-bias curve at the die temperature") {
  PlantParams p = coarse();
  p.arw_deg_per_sqrt_h = 0.0;
  p.bias_instability_dps = 0.0;
  p.zero_rate_offset_mv = 2.0;
  p.zero_bias = gyrotc::model::ZeroBiasCurve({-40.0, 16.0, 80.0}, {40.0, 60.0, 30.0});
  Plant plant(p, 1);
  CHECK(plant.gyro_bias_mv() == Approx(62.0).margin(1e-9));  // 16 C, the initial temperature
}

TEST_CASE("named effects switched on in PlantParams act on the plant") {
  PlantParams base = coarse();
  base.internal_power_w = 0.0;
  PlantParams joule = base;
  joule.effects.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{10.0};
  Plant a(base, 1);
  Plant b(joule, 1);
  for (Plant* plant : {&a, &b}) {
    plant->set_ambient_c(16.0);
    plant->set_tec_enabled(true);
    plant->set_tec_drive_v(stage_drive_v(base, 0.3));
  }
  run(a, 50'000.0);
  run(b, 50'000.0);
  // The casing receives 0.3^2 * 10 / 2 = 0.45 W more.
  CHECK(b.casing_c() - a.casing_c() > 0.1);

  PlantParams warm = base;
  warm.bias_instability_dps = 0.0;
  warm.effects.warm_up = gyrotc::model::WarmUpEffect{5.0, 600.0};
  Plant w(warm, 1);
  CHECK(w.gyro_bias_mv() == Approx(gyrotc::model::table2_bias_mv(16.0) + 5.0));
}

TEST_CASE("parameters that are not physical are rejected with the field's name") {
  PlantParams p;
  p.casing_capacity_j_per_k = 0.0;
  CHECK_THROWS_WITH(Plant(p, 1), Catch::Contains("casing_capacity_j_per_k"));
  PlantParams q;
  q.opa548_restart_c = 170.0;
  CHECK_THROWS_WITH(Plant(q, 1), Catch::Contains("opa548_restart_c"));
}

TEST_CASE("the OPA548 shuts down when its junction overheats and restarts after cooling") {
  PlantParams p;
  p.opa548_theta_ja_c_per_w = 80.0;  // no heat sink: 2.5 W dissipated -> +200 C
  Plant plant(p, 1);
  plant.set_ambient_c(40.0);
  plant.set_tec_enabled(true);
  plant.set_tec_drive_v(stage_drive_v(p, 1.0));
  run(plant, 300.0);
  CHECK(plant.opa548_thermal_shutdown());
  CHECK(plant.tec_current_a() == 0.0);
  plant.set_tec_enabled(false);
  run(plant, 300.0);
  CHECK_FALSE(plant.opa548_thermal_shutdown());
}

TEST_CASE("a unit's zero-rate offset adds to the seed part's bias at every temperature") {
  PlantParams seed_part = coarse();
  seed_part.bias_instability_dps = 0.0;
  PlantParams unit = seed_part;
  unit.zero_rate_offset_mv = 1.5;
  Plant a(seed_part, 1), b(unit, 1);
  for (Plant* p : {&a, &b}) {
    p->set_ambient_c(40.0);
    run(*p, 600.0);
  }
  CHECK(b.gyro_bias_mv() - a.gyro_bias_mv() == Approx(1.5));
}
