#include "gyrotc/algorithms/model/thermal_network.hpp"

#include <cmath>
#include <stdexcept>

namespace gyrotc::model {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("plant network: " + what);
}

bool known(const ThermalNetwork& n, int node) {
  return node == kAmbientNode || (node >= 0 && node < static_cast<int>(n.nodes.size()));
}

void check_sensor(const ThermalNetwork& n, const NetworkSensor& s, const std::string& which) {
  require(known(n, s.node), "sensor '" + which + "' is on a node the network does not have");
  require(std::isfinite(s.tau_s) && s.tau_s >= 0.0, "sensor '" + which + "' tau_s must be zero or positive");
  require(std::isfinite(s.offset_c), "sensor '" + which + "' offset_c must be a number");
  require(std::isfinite(s.noise_c) && s.noise_c >= 0.0, "sensor '" + which + "' noise_c must be zero or positive");
}

}  // namespace

int ThermalNetwork::index_of(const std::string& name) const noexcept {
  if (name == "ambient") return kAmbientNode;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].name == name) return static_cast<int>(i);
  }
  return -2;
}

std::string ThermalNetwork::name_of(int node) const {
  if (node == kAmbientNode) return "ambient";
  if (node >= 0 && node < static_cast<int>(nodes.size())) return nodes[static_cast<std::size_t>(node)].name;
  return "?";
}

void validate(const ThermalNetwork& n) {
  const int count = static_cast<int>(n.nodes.size());
  require(count >= 1, "it has no nodes");
  require(count <= kMaxNetworkNodes, "it has " + std::to_string(count) + " nodes, at most " +
                                         std::to_string(kMaxNetworkNodes) + " are supported");
  for (int i = 0; i < count; ++i) {
    const NetworkNode& node = n.nodes[static_cast<std::size_t>(i)];
    require(!node.name.empty() && node.name != "ambient", "a node may not be called '" + node.name + "'");
    require(n.index_of(node.name) == i, "node '" + node.name + "' is named twice");
    require(std::isfinite(node.capacity_j_per_k) && node.capacity_j_per_k > 0.0,
            "node '" + node.name + "' capacity must be positive (J/K)");
    require(std::isfinite(node.heat_w), "node '" + node.name + "' heat_w must be a number");
  }
  for (const NetworkLink& link : n.links) {
    require(known(n, link.a) && known(n, link.b), "a link names a node the network does not have");
    require(link.a != link.b, "a link joins '" + n.name_of(link.a) + "' to itself");
    require(std::isfinite(link.w_per_k) && link.w_per_k > 0.0,
            "the link between '" + n.name_of(link.a) + "' and '" + n.name_of(link.b) +
                "' must have a positive conductance (W/K)");
  }
  require(known(n, n.tec_from) && known(n, n.tec_to) && n.tec_from != kAmbientNode && n.tec_to != kAmbientNode,
          "the TEC must sit between two nodes of the network (not the ambient: put a sink node between)");
  require(n.tec_from != n.tec_to, "the TEC has both sides on node '" + n.name_of(n.tec_from) + "'");
  // Every node must reach the ambient through links or the TEC's own
  // conductance: otherwise its heat has nowhere to go and its temperature
  // is not defined by the network.
  std::vector<bool> reached(static_cast<std::size_t>(count), false);
  for (bool grew = true; grew;) {
    grew = false;
    auto visit = [&](int from, int to) {
      const bool from_reached = from == kAmbientNode || reached[static_cast<std::size_t>(from)];
      if (from_reached && to != kAmbientNode && !reached[static_cast<std::size_t>(to)]) {
        reached[static_cast<std::size_t>(to)] = true;
        grew = true;
      }
    };
    for (const NetworkLink& link : n.links) {
      visit(link.a, link.b);
      visit(link.b, link.a);
    }
    visit(n.tec_from, n.tec_to);
    visit(n.tec_to, n.tec_from);
  }
  for (int i = 0; i < count; ++i) {
    const std::string& name = n.nodes[static_cast<std::size_t>(i)].name;
    bool linked = n.tec_from == i || n.tec_to == i;
    for (const NetworkLink& link : n.links) linked = linked || link.a == i || link.b == i;
    require(linked, "node '" + name + "' is not reached by any link");
    require(reached[static_cast<std::size_t>(i)], "node '" + name + "' has no path of links to the ambient");
  }
  check_sensor(n, n.casing_sensor, "casing");
  require(n.casing_sensor.node != kAmbientNode, "the casing sensor must sit on a node of the network");
  check_sensor(n, n.ambient_sensor, "ambient");
  require(known(n, n.gyro_node) && n.gyro_node != kAmbientNode, "the gyro must sit on a node of the network");
}

}  // namespace gyrotc::model
