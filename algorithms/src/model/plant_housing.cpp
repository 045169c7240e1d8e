#include "gyrotc/algorithms/model/plant_housing.hpp"

namespace gyrotc::model {

control::HousingModel housing_model(const PlantParams& plant) {
  control::HousingModel m;
  m.seebeck_v_per_k = plant.tec_seebeck_v_per_k;
  m.resistance_ohm = plant.tec_resistance_ohm;
  m.conductance_w_per_k = plant.tec_conductance_w_per_k;
  m.swing_pos_v = plant.supply_pos_v - plant.rail_headroom_v;
  m.swing_neg_v = plant.supply_neg_v + plant.rail_headroom_v;
  m.current_limit_a = plant.current_limit_a;
  if (plant.network) {
    m.network = *plant.network;
    return m;
  }
  // model/plant.hpp's diagram: ambient --G_sa-- shell ==TEC + leak== casing --G_cd-- die.
  ThermalNetwork& n = m.network;
  n.nodes = {{"shell", plant.shell_capacity_j_per_k, 0.0},
             {"casing", plant.casing_capacity_j_per_k, plant.internal_power_w},
             {"die", plant.die_capacity_j_per_k, 0.0}};
  n.links = {{kAmbientNode, 0, plant.shell_ambient_w_per_k},
             {0, 1, plant.shell_casing_leak_w_per_k},
             {1, 2, plant.casing_die_w_per_k}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor = NetworkSensor{1, 0.0, plant.ds18b20_offset_c, 0.0};
  n.ambient_sensor = NetworkSensor{kAmbientNode, 0.0, 0.0, 0.0};
  n.gyro_node = 2;
  return m;
}

}  // namespace gyrotc::model
