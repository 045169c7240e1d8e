#pragma once

#include <string>
#include <vector>

// A lumped thermal network of the user's own housing, for plants that are not
// the seed's three nodes (shell, casing, die): named nodes with heat
// capacities, conductances between nodes or to the ambient, the TEC between
// two nodes, constant heat per node, the DS18B20s on any node with their own
// lag, offset and noise, the gyro die on any node. Plant integrates it with
// backward Euler as it does the default network.
namespace gyrotc::model {

// The chamber: a fixed temperature, not a state of the network.
inline constexpr int kAmbientNode = -1;

struct NetworkNode {
  std::string name;
  double capacity_j_per_k = 0.0;
  double heat_w = 0.0;  // constant heat released in the node (electronics)

  bool operator==(const NetworkNode&) const = default;
};

struct NetworkLink {
  int a = kAmbientNode;  // node index or kAmbientNode
  int b = kAmbientNode;
  double w_per_k = 0.0;

  bool operator==(const NetworkLink&) const = default;
};

// A temperature sensor on a node: a first-order lag (its own package and the
// glue it sits in), a constant offset (the part's calibration error; DS18B20:
// within +/-0.5 C from -10 to 85 C) and white noise per reading.
struct NetworkSensor {
  int node = kAmbientNode;
  double tau_s = 0.0;
  double offset_c = 0.0;
  double noise_c = 0.0;

  bool operator==(const NetworkSensor&) const = default;
};

struct ThermalNetwork {
  std::vector<NetworkNode> nodes;
  std::vector<NetworkLink> links;
  // Positive TEC current pumps heat from tec_from to tec_to (tec_to is the
  // side the default plant calls the casing).
  int tec_from = kAmbientNode;
  int tec_to = kAmbientNode;
  NetworkSensor casing_sensor;
  NetworkSensor ambient_sensor;  // on the ambient unless a file says otherwise
  int gyro_node = kAmbientNode;

  bool operator==(const ThermalNetwork&) const = default;

  // The index of the node called name, kAmbientNode for "ambient", -2 when
  // there is none.
  int index_of(const std::string& name) const noexcept;
  // "ambient" or the node's name.
  std::string name_of(int node) const;
};

// The most nodes a network may have (the solver's fixed workspace).
inline constexpr int kMaxNetworkNodes = 16;

// Throws std::invalid_argument naming what is wrong: no nodes, a
// non-positive capacity, a link to itself or to an unknown node, a
// non-positive conductance, a node no link reaches or one with no path to
// the ambient, a TEC on one node or on the ambient, a sensor or gyro on an
// unknown node, a negative lag or noise.
void validate(const ThermalNetwork& network);

}  // namespace gyrotc::model
