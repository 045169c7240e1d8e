#pragma once

#include "gyrotc/algorithms/model/thermal_network.hpp"

namespace gyrotc::bench {

// A housing of six nodes: the TEC's hot side on a heat sink that warms, the
// casing DS18B20 on a heated board with its own lag, offset and noise, the
// gyro on a mount beside the die, the ambient sensor on the sink.
inline model::ThermalNetwork six_node_housing() {
  using model::kAmbientNode;
  model::ThermalNetwork n;
  n.nodes = {{"sink", 80.0, 0.0}, {"casing", 260.0, 0.0}, {"board", 40.0, 0.3},
             {"mount", 12.0, 0.0}, {"die", 1.6, 0.0},     {"lid", 30.0, 0.0}};
  n.links = {{kAmbientNode, 0, 0.6}, {0, 1, 0.02}, {1, 2, 0.5}, {1, 3, 0.3},
             {3, 4, 0.04},           {1, 5, 0.8},  {kAmbientNode, 5, 0.01}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor = {2, 12.0, 0.15, 0.02};
  n.ambient_sensor = {0, 5.0, -0.1, 0.02};
  n.gyro_node = 4;
  return n;
}

}  // namespace gyrotc::bench
