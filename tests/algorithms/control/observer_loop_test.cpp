#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "gyrotc/algorithms/control/housing_model.hpp"
#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/control/riccati.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::control;
using gyrotc::model::kAmbientNode;

namespace {

// ambient --1 W/K-- sink ==TEC== casing (0.5 W of electronics), the sensor on
// the casing with no lag.
HousingModel two_nodes() {
  HousingModel m;
  m.network.nodes = {{"sink", 50.0, 0.0}, {"casing", 200.0, 0.5}};
  m.network.links = {{kAmbientNode, 0, 1.0}};
  m.network.tec_from = 0;
  m.network.tec_to = 1;
  m.network.casing_sensor = {1, 0.0, 0.0, 0.0};
  m.network.gyro_node = 1;
  m.seebeck_v_per_k = 0.05;
  m.resistance_ohm = 10.0;
  m.conductance_w_per_k = 0.1;
  return m;
}

}  // namespace

TEST_CASE("the Riccati solution of a scalar integrator with unit weights is the golden ratio") {
  const Eigen::MatrixXd one = Eigen::MatrixXd::Constant(1, 1, 1.0);
  const Eigen::MatrixXd p = solve_dare(one, one, one, one);
  CHECK(p(0, 0) == Approx((1.0 + std::sqrt(5.0)) / 2.0).epsilon(1e-10));
}

TEST_CASE("the Riccati equation of an unstable mode no input reaches has no solution") {
  const Eigen::MatrixXd a = Eigen::MatrixXd::Constant(1, 1, 2.0);
  const Eigen::MatrixXd b = Eigen::MatrixXd::Zero(1, 1);
  const Eigen::MatrixXd one = Eigen::MatrixXd::Constant(1, 1, 1.0);
  CHECK_THROWS_AS(solve_dare(a, b, one, one), std::invalid_argument);
}

TEST_CASE("with the TEC off the housing's steady state is the heat over the conductances in series") {
  HousingStepper stepper(two_nodes(), 0.1);
  Eigen::VectorXd x(2);
  stepper.steady_state(x, HousingInput{0.0, 20.0, 0.0});
  // 0.5 W through the TEC's K (0.1 W/K) and the sink's link (1 W/K).
  CHECK(x(0) == Approx(20.0 + 0.5 / 1.0).margin(1e-9));
  CHECK(x(1) == Approx(20.0 + 0.5 / 1.0 + 0.5 / 0.1).margin(1e-9));
  CHECK(stepper.controlled_c(x) == x(1));
}

TEST_CASE("the housing advanced for long with the current held reaches its steady state") {
  HousingStepper stepper(two_nodes(), 0.1);
  const HousingInput in{0.3, 10.0, 0.05};
  Eigen::VectorXd settled(2);
  stepper.steady_state(settled, in);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 10.0);
  stepper.advance(x, 100000.0, in);  // ~40 time constants (200 J/K over K - S I)
  CHECK(x(0) == Approx(settled(0)).margin(1e-6));
  CHECK(x(1) == Approx(settled(1)).margin(1e-6));
}

TEST_CASE("the current the stage applies stops at its own limit and at its output swing") {
  HousingModel m = two_nodes();
  m.current_limit_a = 0.8;
  m.swing_pos_v = 5.0;
  m.swing_neg_v = -5.0;
  HousingStepper stepper(m, 0.1);
  Eigen::VectorXd x(2);
  x << 20.0, 20.0;
  CHECK(stepper.applied_current_a(x, 0.3) == 0.3);
  CHECK(stepper.applied_current_a(x, 2.0) == 0.5);    // 5 V / 10 Ohm
  CHECK(stepper.applied_current_a(x, -0.9) == -0.5);
  m.swing_pos_v = 12.0;
  HousingStepper wide(m, 0.1);
  CHECK(wide.applied_current_a(x, 2.0) == 0.8);       // the limit first
  x << 20.0, 60.0;                                    // the Seebeck voltage takes 2 V of the swing
  CHECK(wide.applied_current_a(x, 2.0) == Approx(0.8));
  CHECK(wide.applied_current_a(x, -2.0) == Approx((-5.0 - 2.0) / 10.0));
}

TEST_CASE("the observer loop's design refuses a setpoint no current can hold") {
  HousingModel m = two_nodes();
  m.seebeck_v_per_k = 0.0;  // no Peltier effect: the TEC only heats
  ObserverLoopSpec spec;
  spec.setpoint_c = 5.0;
  spec.design_ambient_c = 16.0;
  CHECK_THROWS_WITH(design_observer_loop(m, spec), Catch::Contains("no TEC current holds the setpoint"));
}

TEST_CASE("the observer loop's first period starts from the reading and drives towards the setpoint") {
  auto design = std::make_shared<const ObserverLoopDesign>(design_observer_loop(two_nodes(), ObserverLoopSpec{}));
  CHECK(design->observer_radius < 1.0);
  CHECK(design->loop_radius < 1.0);
  ObserverLoop loop(design);
  const double current_a = loop.tick(20.0, 0.0, 20.0, 55.0, -1.0, 1.0);
  CHECK(loop.controlled_estimate_c() == Approx(20.0));
  CHECK(current_a == 1.0);  // far below the setpoint: full heating
  CHECK(loop.saturated());
}

TEST_CASE("the observer loop's filter follows the housing through a stop instead of starting anew") {
  const HousingModel m = two_nodes();
  auto design = std::make_shared<const ObserverLoopDesign>(design_observer_loop(m, ObserverLoopSpec{}));
  ObserverLoop loop(design);
  HousingStepper truth(m, 0.1);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 16.0);
  auto reading = [&] { return std::nearbyint(truth.reading_c(x) * 16.0) / 16.0; };
  for (int k = 0; k < 3000; ++k) {  // warm up and hold
    const double current_a = loop.tick(reading(), 0.0, k % 10 == 0 ? 16.0 : std::nan(""), 55.0, -1.0, 1.0);
    truth.advance(x, 1.0, HousingInput{current_a, 16.0, 0.0});
  }
  REQUIRE(x(1) == Approx(55.0).margin(0.1));
  // A fault: the TEC off for 120 s; the sink (not read) cools towards the room.
  loop.restart(true);
  for (int k = 0; k < 120; ++k) {
    loop.coast(0.0);
    truth.advance(x, 1.0, HousingInput{0.0, 16.0, 0.0});
  }
  loop.tick(reading(), 0.0, 16.0, 55.0, -1.0, 1.0);
  INFO("true sink " << x(0) << " C, estimated " << loop.node_estimate_c(0) << " C; casing " << x(1));
  CHECK(loop.node_estimate_c(0) == Approx(x(0)).margin(0.2));
}

namespace {

// two_nodes() holding 55 C in a 16 C room under its own loop for an hour:
// the loop, and the true state it holds.
struct HeldHousing {
  HousingModel model = two_nodes();
  std::shared_ptr<const ObserverLoopDesign> design =
      std::make_shared<const ObserverLoopDesign>(design_observer_loop(model, ObserverLoopSpec{}));
  ObserverLoop loop{design};
  HousingStepper truth{model, 0.1};
  Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 16.0);
  double current_a = 0.0;

  double reading() const { return std::nearbyint(truth.reading_c(x) * 16.0) / 16.0; }
  HeldHousing() {
    for (int k = 0; k < 3600; ++k) step(loop, k);
  }
  void step(ObserverLoop& l, int k) {
    current_a = l.tick(reading(), 0.0, k % 10 == 0 ? 16.0 : std::nan(""), 55.0, -1.0, 1.0);
    truth.advance(x, 1.0, HousingInput{current_a, 16.0, 0.0});
  }
};

// Another model of the same housing, 30 % off in the sink's loss and the
// TEC's conductance (what a unit's own record may well give).
HousingModel thirty_percent_off(HousingModel m) {
  m.network.links[0].w_per_k *= 1.3;
  m.conductance_w_per_k *= 0.7;
  return m;
}

}  // namespace

TEST_CASE("a loop on another model that adopts a holding loop's handover goes on at the current applied") {
  HeldHousing h;
  REQUIRE(h.x(1) == Approx(55.0).margin(0.1));
  const HousingModel other = thirty_percent_off(h.model);
  ObserverLoop next(std::make_shared<const ObserverLoopDesign>(design_observer_loop(other, ObserverLoopSpec{})));
  const double before_a = h.current_a;
  next.adopt(h.loop.handover());
  const double first_a = next.tick(h.reading(), 0.0, std::nan(""), 55.0, -1.0, 1.0);
  INFO("before " << before_a << " A, first period on the new model " << first_a << " A");
  CHECK(std::fabs(first_a - before_a) < 0.02);
  CHECK_FALSE(next.saturated());
}

TEST_CASE("a loop on another model started from the readings alone kicks the current (what adopt avoids)") {
  HeldHousing h;
  const HousingModel other = thirty_percent_off(h.model);
  ObserverLoop fresh(std::make_shared<const ObserverLoopDesign>(design_observer_loop(other, ObserverLoopSpec{})));
  const double first_a = fresh.tick(h.reading(), 0.0, 16.0, 55.0, -1.0, 1.0);
  CHECK(std::fabs(first_a - h.current_a) > 0.05);
}

TEST_CASE("a loop that adopts a handover holds the housing on from there") {
  HeldHousing h;
  const HousingModel other = thirty_percent_off(h.model);
  ObserverLoop next(std::make_shared<const ObserverLoopDesign>(design_observer_loop(other, ObserverLoopSpec{})));
  next.adopt(h.loop.handover());
  double worst_c = 0.0;
  for (int k = 0; k < 1800; ++k) {
    h.step(next, k);
    worst_c = std::max(worst_c, std::fabs(h.x(1) - 55.0));
  }
  CHECK(worst_c < 0.1);
}

TEST_CASE("a setpoint only a current past the stage's own limit could hold has no holding current, whatever range is searched") {
  const double unlimited_a = holding_current_a(two_nodes(), 55.0, 16.0, 1.0);
  REQUIRE(unlimited_a > 0.0);
  HousingModel m = two_nodes();
  m.current_limit_a = 0.8 * unlimited_a;  // the stage's ILIM
  CHECK(std::isnan(holding_current_a(m, 55.0, 16.0, 1.0)));
  CHECK(std::isnan(holding_current_a(m, 55.0, 16.0, 10.0)));
  m.current_limit_a = 1.2 * unlimited_a;
  CHECK(holding_current_a(m, 55.0, 16.0, 10.0) == Approx(unlimited_a).margin(1e-6));
}

TEST_CASE("where no current cools the casing to the setpoint the loop drives full cooling, not the feedback's heat") {
  // The casing leaks 2 W/K to a 100 C room: holding 55 C would pump 90 W.
  HousingModel m = two_nodes();
  m.network.links.push_back({kAmbientNode, 1, 2.0});
  ObserverLoopSpec spec;
  spec.design_ambient_c = 50.0;
  ObserverLoop loop(std::make_shared<const ObserverLoopDesign>(design_observer_loop(m, spec)));
  for (int k = 0; k < 30; ++k) {
    const double current_a = loop.tick(60.0, 0.0, 100.0, 55.0, -1.0, 1.0);
    INFO("period " << k << ": " << current_a << " A");
    CHECK(current_a == Approx(-1.0).margin(1e-6));
  }
  CHECK(loop.saturated());
}

namespace {

// two_nodes() read through a node of its own that lags the casing by 25 s
// (what tune makes of a record's sensor lag): the loop holds that node.
HousingModel casing_behind_a_lag() {
  HousingModel m = two_nodes();
  m.network.nodes.push_back({"sensor node", 0.2, 0.0});
  m.network.links.push_back({1, 2, 0.2 / 25.0});
  m.network.casing_sensor = {2, 0.0, 0.0, 0.0};
  return m;
}

// The casing's largest excess over the setpoint in a warm-up from 16 C under
// the loop, and the held node's error after an hour.
struct WarmUp {
  double casing_overshoot_c = 0.0;
  double held_error_c = 0.0;
};
WarmUp warm_up_behind_a_lag(double casing_weight) {
  const HousingModel m = casing_behind_a_lag();
  ObserverLoopSpec spec;
  spec.casing_weight = casing_weight;
  ObserverLoop loop(std::make_shared<const ObserverLoopDesign>(design_observer_loop(m, spec)));
  HousingStepper truth(m, 0.1);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(truth.model().state_count(), 16.0);
  WarmUp out;
  for (int k = 0; k < 3600; ++k) {
    const double reading_c = std::nearbyint(truth.reading_c(x) * 16.0) / 16.0;
    const double current_a = loop.tick(reading_c, 0.0, k % 10 == 0 ? 16.0 : std::nan(""), 55.0, -1.0, 1.0);
    truth.advance(x, 1.0, HousingInput{current_a, 16.0, 0.0});
    out.casing_overshoot_c = std::max(out.casing_overshoot_c, x(1) - 55.0);
  }
  out.held_error_c = std::fabs(x(2) - 55.0);
  return out;
}

}  // namespace

TEST_CASE("weighting the casing beside a held lag node brings the warm-up in with less overshoot of the casing") {
  const WarmUp held_alone = warm_up_behind_a_lag(0.0);
  const WarmUp weighted = warm_up_behind_a_lag(0.3);
  INFO("casing overshoot " << held_alone.casing_overshoot_c << " C held alone, " << weighted.casing_overshoot_c
                           << " C weighted");
  CHECK(weighted.casing_overshoot_c < 0.8 * held_alone.casing_overshoot_c);
  CHECK(weighted.held_error_c < 0.05);
}

TEST_CASE("a negative casing weight is refused") {
  ObserverLoopSpec spec;
  spec.casing_weight = -0.1;
  CHECK_THROWS_AS(design_observer_loop(casing_behind_a_lag(), spec), std::invalid_argument);
}
