#pragma once

#include <Eigen/Dense>
#include <limits>

#include "gyrotc/algorithms/model/thermal_network.hpp"

// The housing as the model-based loop sees it (issue 72): a lumped thermal
// network (model/thermal_network.hpp: nodes, links, the TEC between two
// nodes, the casing sensor's node, lag and offset) and the TEC module's
// physics (model/plant.hpp's header): with I positive pumping heat into
// tec_to,
//   into tec_to    S I T_to + I^2 R / 2 + K (T_from - T_to)
//   into tec_from -S I T_from + I^2 R / 2 + K (T_to - T_from)   (T in kelvin),
// plus an unknown heat d (W) into tec_to, the observer's disturbance. With I
// held the network is linear in the temperatures; HousingStepper integrates it
// as the plant does (backward Euler, steps of at most max_step_s), the sensor
// as a first-order lag, and the current the stage applies within its output
// swing: S (T_to - T_from) + I R between swing_neg_v and swing_pos_v (the
// OPA548's rails less its headroom), and within its own current limit.
//
// The state: every node's temperature, then the casing sensor's lagged
// temperature when it has a lag, then the ambient sensor's (on its node or
// on the ambient) when it has one.
namespace gyrotc::control {

struct HousingModel {
  model::ThermalNetwork network;
  double seebeck_v_per_k = 0.0;
  double resistance_ohm = 0.0;
  double conductance_w_per_k = 0.0;
  double swing_pos_v = std::numeric_limits<double>::infinity();
  double swing_neg_v = -std::numeric_limits<double>::infinity();
  double current_limit_a = std::numeric_limits<double>::infinity();

  bool operator==(const HousingModel&) const = default;
  int node_count() const noexcept { return static_cast<int>(network.nodes.size()); }
  bool has_lag() const noexcept { return network.casing_sensor.tau_s > 0.0; }
  bool has_ambient_lag() const noexcept { return network.ambient_sensor.tau_s > 0.0; }
  int casing_lag_index() const noexcept { return has_lag() ? node_count() : -1; }
  int ambient_lag_index() const noexcept { return has_ambient_lag() ? node_count() + (has_lag() ? 1 : 0) : -1; }
  int state_count() const noexcept { return node_count() + (has_lag() ? 1 : 0) + (has_ambient_lag() ? 1 : 0); }
};

// Throws std::invalid_argument naming what is wrong (model::validate, and a
// TEC module that is not physical).
void validate(const HousingModel& model);

// The inputs held over a step.
struct HousingInput {
  double current_a = 0.0;
  double ambient_c = 0.0;
  double disturbance_w = 0.0;
};

// Integrates a HousingModel. Owns its workspace: advance() and
// steady_state() do not allocate once constructed.
class HousingStepper {
 public:
  HousingStepper(const HousingModel& model, double max_step_s);

  // x (state_count() values) over dt_s with the inputs held.
  void advance(Eigen::VectorXd& x, double dt_s, const HousingInput& in) noexcept;
  // The steady state with the inputs held (the lags at their nodes' values),
  // the current within the stage's own limit (current_limit_a; not the
  // rails). False when the housing is not stable at that current (an
  // identified model whose Peltier term, S I T, outgrows its losses): x is
  // then the network's saddle point, no state it settles to.
  bool steady_state(Eigen::VectorXd& x, const HousingInput& in) noexcept;
  // The current the stage applies for a command in state x (its swing).
  double applied_current_a(const Eigen::VectorXd& x, double command_a) const noexcept;
  // The casing sensor's reading of a state (lagged node plus offset), and
  // the ambient sensor's at the ambient ambient_c.
  double reading_c(const Eigen::VectorXd& x) const noexcept;
  double ambient_reading_c(const Eigen::VectorXd& x, double ambient_c) const noexcept;
  // The sensor node's temperature plus the sensor's offset: what the loop
  // holds at the setpoint (model::Plant::controlled_c).
  double controlled_c(const Eigen::VectorXd& x) const noexcept;

  const HousingModel& model() const noexcept { return model_; }

 private:
  // Conductance matrix G and source vector s of C dT/dt = -G T + s.
  void assemble(const HousingInput& in) noexcept;

  HousingModel model_;
  double max_step_s_;
  Eigen::MatrixXd g_;
  Eigen::VectorXd s_;
  Eigen::VectorXd capacity_;
  Eigen::MatrixXd m_;
  Eigen::VectorXd rhs_;
  Eigen::VectorXd nodes_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace gyrotc::control
