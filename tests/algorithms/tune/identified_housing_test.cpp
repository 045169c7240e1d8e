// The identified model as the model-based loop's housing (issue 72, item 2):
// the same physics written as a network, so that the loop predicts what tune
// fitted.
#include <Eigen/Dense>
#include <cmath>

#include "gyrotc/algorithms/control/housing_model.hpp"
#include "gyrotc/algorithms/tune/identified_housing.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

// The nominal plant's record as tune identified it (tune_suite, nominal), a
// rail the stage reaches.
tune::ThermalModel identified() {
  tune::ThermalModel m;
  m.peltier_per_a_s = 1.696e-4;
  m.joule_k_per_a2_s = 0.01987;
  m.loss_per_s = 2.96e-4;
  m.shell_ratio = 5.6;
  m.shell_tau_s = 75.2;
  m.internal_k_per_s = 9.8e-4;
  m.dead_time_s = 1.27;
  m.sensor_lag_s = 0.0;
  m.rail_a = 1.043;
  return m;
}

}  // namespace

TEST_CASE("the identified housing's steady states are the identified model's, heating and cooling") {
  const tune::ThermalModel m = identified();
  control::HousingStepper stepper(tune::identified_housing(m, 1.0), 0.1);
  Eigen::VectorXd x(stepper.model().state_count());
  for (double current_a : {-0.6, 0.0, 0.3, 0.8}) {
    for (double ambient_c : {-20.0, 16.0, 40.0}) {
      const tune::ThermalState want = tune::steady_state(m, current_a, ambient_c);
      stepper.steady_state(x, control::HousingInput{current_a, ambient_c, 0.0});
      INFO(current_a << " A at " << ambient_c << " C");
      CHECK(x(0) == Approx(want.casing_c).margin(1e-6));
      CHECK(x(1) == Approx(want.shell_c).margin(1e-6));
    }
  }
}

TEST_CASE("the identified housing follows the identified model through a warm-up at full current") {
  const tune::ThermalModel m = identified();
  control::HousingStepper stepper(tune::identified_housing(m, 1.0), 0.05);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(stepper.model().state_count(), 16.0);
  tune::ThermalState want{16.0, 16.0};
  for (int s = 0; s < 600; ++s) {
    stepper.advance(x, 1.0, control::HousingInput{0.9, 16.0, 0.0});
    for (int k = 0; k < 20; ++k) want = tune::step(m, want, 0.9, 16.0, 0.05);
  }
  // Backward Euler against the trapezoidal rule, both at 50 ms.
  CHECK(x(0) == Approx(want.casing_c).margin(0.02));
  CHECK(x(1) == Approx(want.shell_c).margin(0.02));
}

TEST_CASE("an identified side node becomes a node on the casing that follows the identified model through a warm-up") {
  tune::ThermalModel m = identified();
  m.side_per_s = 1.3e-3;  // a board of 0.23 of the casing's capacity, 180 s behind it
  m.side_tau_s = 180.0;
  const control::HousingModel housing = tune::identified_housing(m, 1.0);
  REQUIRE(housing.node_count() == 3);
  CHECK(housing.network.nodes[2].capacity_j_per_k == Approx(1.3e-3 * 180.0));
  control::HousingStepper stepper(housing, 0.05);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(stepper.model().state_count(), 16.0);
  tune::ThermalState want{16.0, 16.0, 16.0};
  for (int s = 0; s < 600; ++s) {
    stepper.advance(x, 1.0, control::HousingInput{0.9, 16.0, 0.0});
    for (int k = 0; k < 20; ++k) want = tune::step(m, want, 0.9, 16.0, 0.05);
  }
  INFO("casing " << want.casing_c << " C, side " << want.side_c << " C");
  CHECK(want.casing_c - want.side_c > 2.0);  // the side node lags the warm-up
  CHECK(x(0) == Approx(want.casing_c).margin(0.02));
  CHECK(x(1) == Approx(want.shell_c).margin(0.02));
  CHECK(x(2) == Approx(want.side_c).margin(0.02));
}

TEST_CASE("the identified housing's stage clips the current at the identified rail") {
  const tune::ThermalModel m = identified();
  control::HousingStepper stepper(tune::identified_housing(m, 5.0), 0.1);
  Eigen::VectorXd x(stepper.model().state_count());
  x << 55.0, 20.0, 55.0;  // casing, shell, the reading's lag
  const tune::ThermalState state{55.0, 20.0};
  for (double command_a : {-2.0, -0.5, 0.5, 2.0}) {
    INFO(command_a << " A commanded");
    // thermal_model.cpp rounds its clamp over 3 mA for the fit's sake.
    CHECK(stepper.applied_current_a(x, command_a) == Approx(tune::applied_current_a(m, state, command_a)).margin(0.01));
  }
}

TEST_CASE("a record's lag becomes the sensor's node and its dead time beyond a reading's age the sensor's lag") {
  tune::ThermalModel m = identified();
  const control::HousingModel without = tune::identified_housing(m, 1.0);
  CHECK(without.node_count() == 2);
  CHECK(without.network.casing_sensor.node == 0);
  CHECK(without.network.casing_sensor.tau_s == Approx(0.02));  // 1.27 s of dead time, 1.25 s of it the reading's age
  m.sensor_lag_s = 60.0;
  m.dead_time_s = 14.0;
  const control::HousingModel with = tune::identified_housing(m, 1.0);
  REQUIRE(with.node_count() == 3);
  CHECK(with.network.casing_sensor.node == 2);
  CHECK(with.network.casing_sensor.tau_s == Approx(12.75));
  // The node lags the casing by the identified lag and draws no heat worth the name.
  control::HousingStepper stepper(with, 0.1);
  Eigen::VectorXd x(stepper.model().state_count());
  x << 50.0, 30.0, 40.0, 40.0;
  Eigen::VectorXd y = x;
  stepper.advance(y, 1.0, control::HousingInput{0.0, 16.0, 0.0});
  CHECK((y(2) - x(2)) == Approx((50.0 - 40.0) / 60.0).epsilon(0.02));
}

TEST_CASE("the identified loop's filter takes the record's noise beside the steps, and the heat's scale from the fit") {
  tune::ThermalFit fit;
  fit.model = identified();
  fit.duration_s = 6400.0;
  fit.noise.white_var = 0.02 * 0.02 + 0.0625 * 0.0625 / 12.0;
  fit.estimates.push_back({"internal_k_per_s", "K/s", 9.8e-4, 8e-3, true, ""});
  const control::ObserverLoopSpec spec = tune::identified_observer_spec(fit, 55.0, 1.0, 16.0);
  CHECK(spec.reading_noise_c == Approx(0.02));
  // The heat's scale: its standard error, walked over the record's 6400 s.
  CHECK(spec.initial_heat_w == Approx(8e-2));
  CHECK(spec.disturbance_w_per_sqrt_s == Approx(8e-3 / 80.0));
  fit.noise.white_var = 0.5 * 0.0625 * 0.0625 / 12.0;  // less than the steps' rounding: no noise of its own
  CHECK(tune::identified_observer_spec(fit, 55.0, 1.0, 16.0).reading_noise_c == 0.0);
}
