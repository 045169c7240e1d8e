#include <cmath>
#include <string>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::app;

namespace {

// The housing of issue 35: the TEC's hot side on a heat sink, the casing
// DS18B20 on a board the electronics heat.
const std::string kHousing = R"(format = "gyrotc-plant"
version = 2
[network.nodes]
sink = 80.0
casing = 300.0
board = 40.0
die = 1.6
[[network.links]]
between = ["ambient", "sink"]
w_per_k = 0.6
[[network.links]]
between = ["sink", "casing"]
w_per_k = 0.02
[[network.links]]
between = ["casing", "board"]
w_per_k = 0.5
[[network.links]]
between = ["casing", "die"]
w_per_k = 0.04
[network.tec]
between = ["sink", "casing"]
[network.heat_w]
board = 0.3
[network.sensors.casing]
node = "board"
tau_s = 12.0
offset_c = 0.15
noise_c = 0.02
[network.gyro]
node = "die"
)";

// kHousing with one line replaced (the first occurrence of from).
std::string housing_with(const std::string& from, const std::string& to) {
  std::string text = kHousing;
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

void refused(const std::string& text, const std::string& message) {
  CHECK_THROWS_WITH(parse_plant(text, "p.toml"), Catch::Contains(message));
}

}  // namespace

TEST_CASE("a network plant file loads its nodes, links, TEC, heat, sensors and gyro") {
  const auto p = parse_plant(kHousing, "p.toml");
  REQUIRE(p.network);
  const auto& n = *p.network;
  REQUIRE(n.nodes.size() == 4);
  CHECK(n.nodes[static_cast<std::size_t>(n.index_of("casing"))].capacity_j_per_k == 300.0);
  CHECK(n.nodes[static_cast<std::size_t>(n.index_of("board"))].heat_w == 0.3);
  CHECK(n.links.size() == 4);
  CHECK(n.name_of(n.tec_from) == "sink");
  CHECK(n.name_of(n.tec_to) == "casing");
  CHECK(n.name_of(n.casing_sensor.node) == "board");
  CHECK(n.casing_sensor.tau_s == 12.0);
  CHECK(n.casing_sensor.offset_c == 0.15);
  CHECK(n.casing_sensor.noise_c == 0.02);
  CHECK(n.name_of(n.ambient_sensor.node) == "ambient");
  CHECK(n.name_of(n.gyro_node) == "die");
}

TEST_CASE("a network plant file reads back what format_plant writes") {
  const auto p = parse_plant(housing_with("noise_c = 0.02", "noise_c = 0.02\n[gyro]\nzero_rate_offset_mv = 3.5"),
                             "p.toml");
  const auto q = parse_plant(format_plant(p), "round-trip.toml");
  REQUIRE(q.network);
  CHECK(format_plant(q) == format_plant(p));
  CHECK(q.zero_rate_offset_mv == 3.5);
  CHECK(q.network->casing_sensor.offset_c == 0.15);
}

TEST_CASE("a network plant file names the line of a node no link reaches") {
  refused(housing_with("die = 1.6", "die = 1.6\nmount = 5.0"), "p.toml:8: plant network: node 'mount' is not reached");
}

TEST_CASE("a network plant file names the line of a TEC on one node") {
  refused(housing_with("between = [\"sink\", \"casing\"]\n[network.heat_w]", "between = [\"sink\", \"sink\"]\n[network.heat_w]"),
          "the TEC has both sides on node 'sink'");
}

TEST_CASE("a network plant file names the line of a sensor on a missing node") {
  refused(housing_with("node = \"board\"", "node = \"pcb\""),
          "p.toml:25: key 'network.sensors.casing.node' names node 'pcb', which [network.nodes] does not have");
}

TEST_CASE("a network plant file names the line of a link to a missing node") {
  refused(housing_with("between = [\"casing\", \"board\"]", "between = [\"casing\", \"bord\"]"),
          "p.toml:15: key 'network.links.between' names node 'bord'");
}

TEST_CASE("a network plant file needs version 2") {
  refused(housing_with("version = 2", "version = 1"), "a [network] plant needs 'version = 2'");
}

TEST_CASE("a network plant file refuses the default network's [thermal] beside it") {
  refused(kHousing + "[thermal]\ncasing_capacity_j_per_k = 10.0\n", "[thermal] sets the default three-node network");
}

TEST_CASE("a network plant file refuses the default network's sensor offset beside it") {
  refused(kHousing + "[sensors]\nds18b20_offset_c = 0.1\n", "'network.sensors.casing.offset_c'");
}

TEST_CASE("a network plant file refuses an unknown key, by its name") {
  refused(housing_with("tau_s = 12.0", "tau_s = 12.0\nlag_s = 3.0"), "unknown key 'network.sensors.casing.lag_s'");
}

TEST_CASE("a network plant file needs its casing sensor and its gyro") {
  refused(housing_with("[network.sensors.casing]\nnode = \"board\"", "[network.sensors.ambient]\nnode = \"sink\""),
          "'network.sensors' needs the key 'casing'");
  refused(housing_with("[network.gyro]\nnode = \"die\"", ""), "'network' needs the key 'gyro'");
}

TEST_CASE("a network plant's record shows the casing sensor's node plus its offset as the casing") {
  SimulationSetup setup;
  setup.plant = parse_plant(kHousing, "p.toml");
  setup.controller = controller_preset(ControllerMode::off, setup.plant);
  static const auto calibration = gyrotc::fit::BiasModel::paper_reference();
  setup.calibration = &calibration;
  setup.sample_rate_hz = 50.0;
  const gyrotc::model::ChamberProfile profile({{"hold", 0.0, 40000.0, 20.0, 20.0}});
  const auto r = run_simulation(setup, profile);
  const auto& last = r.rows.back();
  // TEC off, steady state: the board's 0.3 W leaves through board-casing
  // (0.5 W/K), casing-sink (the leak 0.02 and the TEC's K 0.085) and
  // sink-ambient (0.6); the die, a dead end, sits at the casing.
  const double casing_node_c = 20.0 + 0.3 * (1.0 / 0.105 + 1.0 / 0.6);
  const double board_c = casing_node_c + 0.3 / 0.5;
  CHECK(last.casing_c == Approx(board_c + 0.15).margin(0.01));
  CHECK(last.die_c == Approx(casing_node_c).margin(0.01));
}
