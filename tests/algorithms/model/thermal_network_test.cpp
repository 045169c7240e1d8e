#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/algorithms/model/thermal_network.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::model::kAmbientNode;
using gyrotc::model::Plant;
using gyrotc::model::PlantParams;
using gyrotc::model::stage_drive_v;
using gyrotc::model::ThermalNetwork;

namespace {

// The default plant's three nodes written as a network: shell 0, casing 1, die 2.
ThermalNetwork default_as_network(const PlantParams& p) {
  ThermalNetwork n;
  n.nodes = {{"shell", p.shell_capacity_j_per_k, 0.0},
             {"casing", p.casing_capacity_j_per_k, p.internal_power_w},
             {"die", p.die_capacity_j_per_k, 0.0}};
  n.links = {{kAmbientNode, 0, p.shell_ambient_w_per_k}, {0, 1, p.shell_casing_leak_w_per_k},
             {1, 2, p.casing_die_w_per_k}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor.node = 1;
  n.gyro_node = 2;
  return n;
}

// A node that follows the ambient within milliseconds, carrying a sensor.
PlantParams fast_node_with_sensor(double tau_s, double offset_c, double noise_c) {
  PlantParams p;
  ThermalNetwork n;
  n.nodes = {{"sink", 50.0, 0.0}, {"mount", 0.01, 0.0}};
  n.links = {{kAmbientNode, 0, 1.0}, {kAmbientNode, 1, 1.0}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor = {1, tau_s, offset_c, noise_c};
  n.gyro_node = 1;
  p.network = n;
  p.tec_conductance_w_per_k = 0.0;
  return p;
}

void expect_invalid(const ThermalNetwork& n, const std::string& text) {
  CHECK_THROWS_WITH(gyrotc::model::validate(n), Catch::Contains(text));
}

}  // namespace

TEST_CASE("the default plant written as a network simulates as the default plant, heating and cooling") {
  PlantParams p;
  PlantParams q = p;
  q.network = default_as_network(p);
  for (const double current_a : {0.6, -0.6}) {
    Plant a(p, 3);
    Plant b(q, 3);
    for (Plant* plant : {&a, &b}) {
      plant->set_ambient_c(20.0);
      plant->set_tec_enabled(true);
      plant->set_tec_drive_v(stage_drive_v(p, current_a));
    }
    for (int k = 0; k < 3000; ++k) {
      a.advance(1.0);
      b.advance(1.0);
      REQUIRE(b.casing_c() == Approx(a.casing_c()).margin(1e-9));
      REQUIRE(b.shell_c() == Approx(a.shell_c()).margin(1e-9));
      REQUIRE(b.die_c() == Approx(a.die_c()).margin(1e-9));
    }
    CHECK(std::fabs(a.casing_c() - 20.0) > 5.0);  // the TEC moved it
    CHECK(b.tec_voltage_v() == Approx(a.tec_voltage_v()).margin(1e-9));
    CHECK(b.sensor_c() == Approx(a.sensor_c()).margin(1e-9));
    CHECK(b.controlled_c() == Approx(a.controlled_c()).margin(1e-9));
  }
}

TEST_CASE("a network plant's casing-to-ambient conductance and die time constant match the default network's") {
  PlantParams p;
  PlantParams q = p;
  q.network = default_as_network(p);
  CHECK(q.casing_ambient_w_per_k() == Approx(p.casing_ambient_w_per_k()).epsilon(1e-12));
  CHECK(q.die_tau_s() == Approx(p.die_tau_s()).epsilon(1e-12));
}

TEST_CASE("a network node's constant heat leaves through the links at steady state") {
  PlantParams p;
  p.max_thermal_step_s = 5.0;
  p.tec_conductance_w_per_k = 0.0;
  ThermalNetwork n;
  // ambient -1 W/K- sink -0.5 W/K- board (0.3 W): board = 20 + 0.3 (1 + 2).
  n.nodes = {{"sink", 80.0, 0.0}, {"board", 40.0, 0.3}};
  n.links = {{kAmbientNode, 0, 1.0}, {0, 1, 0.5}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor.node = 1;
  n.gyro_node = 1;
  p.network = n;
  Plant plant(p, 1);
  plant.set_ambient_c(20.0);
  plant.advance(20000.0);
  plant.flush();
  CHECK(plant.node_c(0) == Approx(20.3).margin(1e-6));
  CHECK(plant.node_c(1) == Approx(20.9).margin(1e-6));
}

TEST_CASE("the casing sensor lags its node by its own time constant") {
  PlantParams p = fast_node_with_sensor(20.0, 0.0, 0.0);
  Plant plant(p, 1);
  plant.set_ambient_c(26.0);  // a 10 C step from 16 C
  plant.advance(20.0);
  plant.flush();
  CHECK(plant.casing_c() == Approx(26.0).margin(1e-3));
  CHECK(plant.sensor_c() == Approx(26.0 - 10.0 * std::exp(-1.0)).margin(0.05));
  CHECK(plant.controlled_c() == Approx(26.0).margin(1e-3));  // what is held has no lag
}

TEST_CASE("the casing sensor's offset is in its readings and in the controlled temperature, its noise only in the readings") {
  PlantParams p = fast_node_with_sensor(0.0, 0.15, 0.02);
  Plant plant(p, 1);
  plant.set_ambient_c(30.0);
  plant.advance(10.0);
  plant.flush();
  std::vector<double> readings;
  for (int k = 0; k < 4000; ++k) {
    plant.advance(p.max_thermal_step_s);
    readings.push_back(plant.sensor_c());
    REQUIRE(plant.controlled_c() == Approx(30.15).margin(1e-6));
  }
  double mean = 0.0;
  for (double r : readings) mean += r / static_cast<double>(readings.size());
  double var = 0.0;
  for (double r : readings) var += (r - mean) * (r - mean) / static_cast<double>(readings.size() - 1);
  CHECK(mean == Approx(30.15).margin(0.002));
  CHECK(std::sqrt(var) == Approx(0.02).epsilon(0.05));
}

TEST_CASE("the ambient sensor can sit on a node with its own lag and offset") {
  PlantParams p = fast_node_with_sensor(0.0, 0.0, 0.0);
  p.network->ambient_sensor = {0, 0.0, -0.25, 0.0};  // on the sink (tau 50 s)
  Plant plant(p, 1);
  plant.set_ambient_c(26.0);
  plant.advance(50.0);
  plant.flush();
  CHECK(plant.ambient_sensor_c() == Approx(26.0 - 10.0 * std::exp(-1.0) - 0.25).margin(0.05));
}

TEST_CASE("a sensor's noise leaves the gyro's samples as they were") {
  PlantParams quiet = fast_node_with_sensor(0.0, 0.0, 0.0);
  PlantParams noisy = fast_node_with_sensor(0.0, 0.0, 0.5);
  Plant a(quiet, 9);
  Plant b(noisy, 9);
  bool sensors_differ = false;
  for (int k = 0; k < 5000; ++k) {
    a.advance(0.001);
    b.advance(0.001);
    REQUIRE(a.gyro_mv(0.001) == b.gyro_mv(0.001));
    sensors_differ = sensors_differ || a.sensor_c() != b.sensor_c();
  }
  CHECK(sensors_differ);
}

TEST_CASE("a network with no nodes is refused") { expect_invalid(ThermalNetwork{}, "no nodes"); }

TEST_CASE("a network node that no link reaches is refused, by name") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.nodes.push_back({"board", 40.0, 0.0});
  expect_invalid(n, "node 'board' is not reached by any link");
}

TEST_CASE("a network island with no path to the ambient is refused, by name") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.nodes.push_back({"board", 40.0, 0.0});
  n.nodes.push_back({"mount", 10.0, 0.0});
  n.links.push_back({3, 4, 0.1});
  expect_invalid(n, "node 'board' has no path of links to the ambient");
}

TEST_CASE("a TEC with both sides on one node is refused") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.tec_to = n.tec_from;
  expect_invalid(n, "the TEC has both sides on node 'shell'");
}

TEST_CASE("a TEC on the ambient is refused") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.tec_from = kAmbientNode;
  expect_invalid(n, "the TEC must sit between two nodes");
}

TEST_CASE("a sensor on a node the network does not have is refused") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.casing_sensor.node = 7;
  expect_invalid(n, "sensor 'casing' is on a node the network does not have");
}

TEST_CASE("a negative sensor lag or noise is refused") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.casing_sensor.tau_s = -1.0;
  expect_invalid(n, "tau_s must be zero or positive");
  n.casing_sensor.tau_s = 1.0;
  n.ambient_sensor.noise_c = -0.1;
  expect_invalid(n, "sensor 'ambient' noise_c must be zero or positive");
}

TEST_CASE("a link with no conductance is refused, naming its nodes") {
  ThermalNetwork n = default_as_network(PlantParams{});
  n.links[1].w_per_k = 0.0;
  expect_invalid(n, "the link between 'shell' and 'casing' must have a positive conductance");
}
