#include <cmath>

#include "gyrotc/algorithms/model/effects.hpp"
#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::model::Effects;
using gyrotc::model::GyroEffectState;

TEST_CASE("with no effect switched on the bias is evaluated at the temperature itself, unchanged") {
  GyroEffectState state(Effects{});
  state.reset(20.0);
  for (int i = 0; i < 100; ++i) state.advance(1.0, 20.0 + 0.1 * i);
  CHECK(state.bias_temp_c() == Approx(20.0 + 9.9));
  CHECK(state.extra_bias_mv() == 0.0);
}

TEST_CASE("thermal_lag: on a steady ramp the die trails the temperature by tau times the rate") {
  Effects e;
  e.thermal_lag = gyrotc::model::ThermalLagEffect{120.0};
  GyroEffectState state(e);
  state.reset(0.0);
  const double rate = 0.02;  // C/s
  for (int i = 1; i <= 2000; ++i) state.advance(1.0, rate * i);
  CHECK(state.temp_c() - state.bias_temp_c() == Approx(120.0 * rate).epsilon(1e-6));
}

TEST_CASE("thermal_lag is independent of the step size (exact update)") {
  Effects e;
  e.thermal_lag = gyrotc::model::ThermalLagEffect{60.0};
  GyroEffectState coarse(e);
  GyroEffectState fine(e);
  coarse.reset(10.0);
  fine.reset(10.0);
  for (int i = 1; i <= 30; ++i) coarse.advance(10.0, 10.0 + 0.05 * 10.0 * i);
  for (int i = 1; i <= 3000; ++i) fine.advance(0.1, 10.0 + 0.05 * 0.1 * i);
  CHECK(coarse.bias_temp_c() == Approx(fine.bias_temp_c()).epsilon(1e-9));
}

TEST_CASE("additive effects: rate, ramp direction, warm-up and drift add their terms") {
  Effects e;
  e.rate_sensitivity = gyrotc::model::RateSensitivityEffect{50.0};
  e.ramp_hysteresis = gyrotc::model::RampHysteresisEffect{2.0, 0.001};
  e.warm_up = gyrotc::model::WarmUpEffect{3.0, 600.0};
  e.linear_drift = gyrotc::model::LinearDriftEffect{0.5};
  GyroEffectState state(e);
  state.reset(25.0);
  state.advance(600.0, 25.0 + 600.0 * 0.01);  // 0.01 C/s
  const double expected = 50.0 * 0.01 + 2.0 * std::tanh(10.0) + 3.0 * std::exp(-1.0) + 0.5 * 600.0 / 3600.0;
  CHECK(state.extra_bias_mv() == Approx(expected));
}

TEST_CASE("tec_joule_heating adds half of I^2 R to the casing") {
  Effects e;
  CHECK(gyrotc::model::tec_joule_heat_w(e, 2.0) == 0.0);
  e.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{1.5};
  CHECK(gyrotc::model::tec_joule_heat_w(e, 2.0) == Approx(3.0));
  CHECK(gyrotc::model::tec_joule_heat_w(e, -2.0) == Approx(3.0));
}

TEST_CASE("ambient_sensitivity adds k times the ambient's departure from its reference") {
  Effects e;
  e.ambient_sensitivity = gyrotc::model::AmbientSensitivityEffect{0.2, 25.0};
  GyroEffectState state(e);
  state.reset(30.0);
  CHECK(state.extra_bias_mv() == 0.0);  // the ambient not yet set reads as the reference
  state.set_ambient_c(45.0);
  state.advance(1.0, 30.0);
  CHECK(state.extra_bias_mv() == Approx(0.2 * 20.0));
}

TEST_CASE("the plant applies ambient_sensitivity: same seed, same thermal history, bias shifted by k (T_amb - ref)") {
  gyrotc::model::PlantParams base;
  gyrotc::model::PlantParams with = base;
  with.effects.ambient_sensitivity = gyrotc::model::AmbientSensitivityEffect{0.3, 25.0};
  gyrotc::model::Plant a(base, 9);
  gyrotc::model::Plant b(with, 9);
  for (auto* p : {&a, &b}) {
    p->set_ambient_c(40.0);
    p->advance(120.0);
    p->flush();
  }
  CHECK(b.casing_c() == a.casing_c());
  CHECK(b.gyro_bias_mv() - a.gyro_bias_mv() == Approx(0.3 * (40.0 - 25.0)).epsilon(1e-9));
}
