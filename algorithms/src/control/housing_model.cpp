#include "gyrotc/algorithms/control/housing_model.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gyrotc::control {
namespace {

constexpr double kKelvin = 273.15;

}  // namespace

void validate(const HousingModel& model) {
  model::validate(model.network);
  if (!(std::isfinite(model.seebeck_v_per_k) && model.seebeck_v_per_k >= 0.0) ||
      !(std::isfinite(model.resistance_ohm) && model.resistance_ohm > 0.0) ||
      !(std::isfinite(model.conductance_w_per_k) && model.conductance_w_per_k >= 0.0) ||
      !(model.swing_neg_v < model.swing_pos_v) || !(model.current_limit_a > 0.0)) {
    throw std::invalid_argument(
        "housing model: the TEC's Seebeck coefficient and conductance must be zero or positive, its resistance "
        "positive, the stage's swing an interval and its current limit positive");
  }
}

HousingStepper::HousingStepper(const HousingModel& model, double max_step_s)
    : model_(model), max_step_s_(max_step_s) {
  validate(model_);
  if (!(max_step_s_ > 0.0)) throw std::invalid_argument("housing model: the step must be positive");
  const int n = model_.node_count();
  g_.setZero(n, n);
  s_.setZero(n);
  capacity_.resize(n);
  for (int i = 0; i < n; ++i) capacity_(i) = model_.network.nodes[static_cast<std::size_t>(i)].capacity_j_per_k;
  m_.setZero(n, n);
  rhs_.setZero(n);
  nodes_.setZero(n);
  lu_ = Eigen::PartialPivLU<Eigen::MatrixXd>(n);
}

void HousingStepper::assemble(const HousingInput& in) noexcept {
  const model::ThermalNetwork& net = model_.network;
  const int n = model_.node_count();
  g_.setZero();
  for (int i = 0; i < n; ++i) s_(i) = net.nodes[static_cast<std::size_t>(i)].heat_w;
  auto conduct = [&](int a, int b, double w) {
    if (a != model::kAmbientNode) g_(a, a) += w;
    if (b != model::kAmbientNode) g_(b, b) += w;
    if (a == model::kAmbientNode) {
      s_(b) += w * in.ambient_c;
    } else if (b == model::kAmbientNode) {
      s_(a) += w * in.ambient_c;
    } else {
      g_(a, b) -= w;
      g_(b, a) -= w;
    }
  };
  for (const model::NetworkLink& link : net.links) conduct(link.a, link.b, link.w_per_k);
  conduct(net.tec_from, net.tec_to, model_.conductance_w_per_k);
  const double si = model_.seebeck_v_per_k * in.current_a;
  const double joule_half_w = 0.5 * in.current_a * in.current_a * model_.resistance_ohm;
  g_(net.tec_from, net.tec_from) += si;
  g_(net.tec_to, net.tec_to) -= si;
  s_(net.tec_from) += -si * kKelvin + joule_half_w;
  s_(net.tec_to) += si * kKelvin + joule_half_w + in.disturbance_w;
}

void HousingStepper::advance(Eigen::VectorXd& x, double dt_s, const HousingInput& in) noexcept {
  if (!(dt_s > 0.0)) return;
  const int n = model_.node_count();
  const model::NetworkSensor& sensor = model_.network.casing_sensor;
  const model::NetworkSensor& ambient_sensor = model_.network.ambient_sensor;
  const long steps = std::max(1L, static_cast<long>(std::ceil(dt_s / max_step_s_ - 1e-9)));
  const double h = dt_s / static_cast<double>(steps);
  const double lag_keep = model_.has_lag() ? std::exp(-h / sensor.tau_s) : 0.0;
  const double ambient_lag_keep = model_.has_ambient_lag() ? std::exp(-h / ambient_sensor.tau_s) : 0.0;
  HousingInput step_in = in;
  bool assembled = false;
  for (long k = 0; k < steps; ++k) {
    // As the plant: the stage's swing applied at each step's start.
    const double applied_a = applied_current_a(x, in.current_a);
    if (!assembled || applied_a != step_in.current_a) {
      step_in.current_a = applied_a;
      assemble(step_in);
      m_ = g_;
      m_.diagonal() += capacity_ / h;
      lu_.compute(m_);
      assembled = true;
    }
    rhs_ = s_;
    rhs_.array() += capacity_.array() / h * x.head(n).array();
    nodes_.noalias() = lu_.solve(rhs_);
    x.head(n) = nodes_;
    // As the plant's sensors: exact for the node held over the step.
    if (model_.has_lag()) {
      const double now_c = x(sensor.node);
      x(n) = now_c + (x(n) - now_c) * lag_keep;
    }
    if (model_.has_ambient_lag()) {
      const int i = model_.ambient_lag_index();
      const double now_c = ambient_sensor.node == model::kAmbientNode ? in.ambient_c : x(ambient_sensor.node);
      x(i) = now_c + (x(i) - now_c) * ambient_lag_keep;
    }
  }
}

bool HousingStepper::steady_state(Eigen::VectorXd& x, const HousingInput& in) noexcept {
  const int n = model_.node_count();
  // The stage gives at most its limit. Beyond it the Peltier term (S I T,
  // growing with the temperature it heats) can outweigh an identified
  // model's losses: the linear steady state is then a saddle hundreds of
  // kelvin off, and a holding-current search that stepped there steered by it.
  HousingInput held = in;
  held.current_a = std::clamp(in.current_a, -model_.current_limit_a, model_.current_limit_a);
  assemble(held);
  lu_.compute(g_);
  nodes_.noalias() = lu_.solve(s_);
  x.head(n) = nodes_;
  if (model_.has_lag()) x(n) = x(model_.network.casing_sensor.node);
  if (model_.has_ambient_lag()) {
    const int node = model_.network.ambient_sensor.node;
    x(model_.ambient_lag_index()) = node == model::kAmbientNode ? in.ambient_c : x(node);
  }
  // G's eigenvalues are the network's decay rates (times the capacities):
  // positive for a physical housing, and the first that the Peltier term
  // drives through zero turns the determinant's sign.
  return lu_.determinant() > 0.0;
}

double HousingStepper::applied_current_a(const Eigen::VectorXd& x, double command_a) const noexcept {
  const model::ThermalNetwork& net = model_.network;
  const double seebeck_v = model_.seebeck_v_per_k * (x(net.tec_to) - x(net.tec_from));
  const double hi_a = std::min(model_.current_limit_a, (model_.swing_pos_v - seebeck_v) / model_.resistance_ohm);
  const double lo_a = std::max(-model_.current_limit_a, (model_.swing_neg_v - seebeck_v) / model_.resistance_ohm);
  return std::clamp(command_a, std::min(lo_a, hi_a), std::max(lo_a, hi_a));
}

double HousingStepper::reading_c(const Eigen::VectorXd& x) const noexcept {
  const model::NetworkSensor& sensor = model_.network.casing_sensor;
  return (model_.has_lag() ? x(model_.node_count()) : x(sensor.node)) + sensor.offset_c;
}

double HousingStepper::ambient_reading_c(const Eigen::VectorXd& x, double ambient_c) const noexcept {
  const model::NetworkSensor& sensor = model_.network.ambient_sensor;
  const double seen_c = model_.has_ambient_lag()                 ? x(model_.ambient_lag_index())
                        : sensor.node == model::kAmbientNode ? ambient_c
                                                             : x(sensor.node);
  return seen_c + sensor.offset_c;
}

double HousingStepper::controlled_c(const Eigen::VectorXd& x) const noexcept {
  const model::NetworkSensor& sensor = model_.network.casing_sensor;
  return x(sensor.node) + sensor.offset_c;
}

}  // namespace gyrotc::control
