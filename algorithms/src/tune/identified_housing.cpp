#include "gyrotc/algorithms/tune/identified_housing.hpp"

#include <algorithm>
#include <cmath>

namespace gyrotc::tune {

namespace {

// The dead time beyond a reading's own age in the record (a DS18B20 reading
// is converted in 0.75 s and delivered once a second: 1.25 s old on average),
// which the loop is told reading by reading: what is left is the housing's,
// taken as part of the sensor's lag (a first-order stand-in for a delay).
double excess_dead_time_s(const ThermalModel& m) { return std::max(0.0, m.dead_time_s - 1.25); }

// The band of ambients the loop is judged on (seed Section 6.2), and a
// current limit beyond any stage's for the holding current's search there.
constexpr double kHeldBandLowC = -20.0;
constexpr double kHeldBandHighC = 35.0;
constexpr double kHoldLimitA = 10.0;

// A lag shorter than this is the casing's own reading.
constexpr double kLeastLagS = 1.0;
// The lag node's capacity per the casing's: its heat is a rounding error.
constexpr double kLagNodeCapacity = 1e-3;
// The casing's share of the LQ cost beside that node (ObserverLoopSpec::
// casing_weight): the lag may be the DS18B20's package on the casing or a node
// of its own, and a record cannot tell (how 0.3 was chosen and checked:
// docs/TUNING.md, section 7).
constexpr double kCasingWeight = 0.3;

}  // namespace

control::HousingModel identified_housing(const ThermalModel& m, double current_limit_a) {
  control::HousingModel h;
  h.seebeck_v_per_k = m.peltier_per_a_s;
  h.resistance_ohm = 2.0 * m.joule_k_per_a2_s;
  h.conductance_w_per_k = m.casing_shell_per_s();
  // thermal_model.hpp: I within +/- rail_a - (S/R)(Tc - Ts), i.e.
  // S (Tc - Ts) + I R within +/- rail_a R.
  h.swing_pos_v = m.rail_a * h.resistance_ohm;
  h.swing_neg_v = -h.swing_pos_v;
  // The loop's limit, or the stage's own where it gives less (its ILIM).
  h.current_limit_a = std::min(current_limit_a, m.stage_limit_a);
  model::ThermalNetwork& n = h.network;
  const double shell_capacity = 1.0 / m.capacity_ratio();
  n.nodes = {{"casing", 1.0, m.internal_k_per_s}, {"shell", shell_capacity, 0.0}};
  n.links = {{1, model::kAmbientNode, m.shell_ambient_per_s() * shell_capacity}};
  n.tec_from = 1;
  n.tec_to = 0;
  n.gyro_node = 0;
  n.casing_sensor = model::NetworkSensor{0, excess_dead_time_s(m), 0.0, 0.0};
  if (m.sensor_lag_s > kLeastLagS || m.sensor_ambient_share > 0.0) {
    // The identified lag as a node of its own between the casing and the
    // sensor (a capacity too small to draw heat from the casing), the dead
    // time as the sensor's own lag behind it: the loop holds that node. The
    // node's links share its time constant as the sensor's input does:
    // (1 - q) to the casing, q to the ambient (thermal_model.hpp).
    const double lag_s = std::max(m.sensor_lag_s, kLeastLagS);
    const double q = m.sensor_ambient_share;
    n.nodes.push_back({"sensor node", kLagNodeCapacity, 0.0});
    n.links.push_back({0, 2, (1.0 - q) * kLagNodeCapacity / lag_s});
    if (q > 0.0) n.links.push_back({2, model::kAmbientNode, q * kLagNodeCapacity / lag_s});
    n.casing_sensor.node = 2;
  }
  if (m.side_per_s > 0.0) {
    // The side node: G_side = h, C_side = h tau_b, per unit of the casing's capacity.
    n.nodes.push_back({"side node", m.side_per_s * m.side_tau_s, 0.0});
    n.links.push_back({0, static_cast<int>(n.nodes.size()) - 1, m.side_per_s});
  }
  n.ambient_sensor = model::NetworkSensor{model::kAmbientNode, 0.0, 0.0, 0.0};
  control::validate(h);
  return h;
}

control::ObserverLoopSpec identified_observer_spec(const ThermalFit& fit, double setpoint_c, double period_s,
                                                   double design_ambient_c) {
  control::ObserverLoopSpec spec;
  spec.period_s = period_s;
  spec.setpoint_c = setpoint_c;
  spec.design_ambient_c = design_ambient_c;
  spec.casing_weight = kCasingWeight;
  double heat_se = 0.0;
  for (const Estimate& e : fit.estimates) {
    if (e.name == "internal_k_per_s") heat_se = e.std_error;
  }
  // A heat the record pins down closely is still a heat the model may get
  // wrong as the ambient moves: at least the uncertainty of the heat the TEC
  // must give to hold the setpoint at either end of the band the loop is
  // judged on (seed Section 6.2), from the fit's covariance.
  if (fit.covariance.rows() > 0) {
    for (const double ambient_c : {kHeldBandLowC, kHeldBandHighC}) {
      const double i = holding_current_a(fit.model, setpoint_c, ambient_c, kHoldLimitA);
      if (!std::isfinite(i)) continue;
      const double current_se = std_error_of(
          fit, [&](const ThermalModel& m) { return holding_current_a(m, setpoint_c, ambient_c, kHoldLimitA); });
      const double gain = casing_gain_k_per_a_s(fit.model, steady_state(fit.model, i, ambient_c), i);
      if (std::isfinite(current_se)) heat_se = std::max(heat_se, current_se * gain);
    }
  }
  // The readings' own noise: the fit's white residual less the steps'
  // rounding (a uniform error of one step), which the filter takes as such.
  const double rounding_var = spec.reading_step_c * spec.reading_step_c / 12.0;
  spec.reading_noise_c = std::sqrt(std::max(0.0, fit.noise.white_var - rounding_var));
  spec.ambient_noise_c = spec.reading_noise_c;
  spec.initial_heat_w = 10.0 * heat_se;
  spec.disturbance_w_per_sqrt_s = heat_se / std::sqrt(std::max(fit.duration_s, 1.0));
  return spec;
}

}  // namespace gyrotc::tune
