#include "gyrotc/algorithms/model/plant.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace gyrotc::model {
namespace {

constexpr double kKelvin = 273.15;

void require(bool ok, const char* field, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("plant parameter ") + field + " " + what);
}

}  // namespace

double PlantParams::casing_ambient_w_per_k() const {
  if (!network) {
    const double parallel = tec_conductance_w_per_k + shell_casing_leak_w_per_k;
    return 1.0 / (1.0 / shell_ambient_w_per_k + 1.0 / parallel);
  }
  // 1 W into the sensor's node, the ambient at 0: G T = e, and 1 / T there.
  const ThermalNetwork& n = *network;
  const int count = static_cast<int>(n.nodes.size());
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(count, count);
  auto conduct = [&](int a, int b, double w_per_k) {
    if (a != kAmbientNode) g(a, a) += w_per_k;
    if (b != kAmbientNode) g(b, b) += w_per_k;
    if (a != kAmbientNode && b != kAmbientNode) {
      g(a, b) -= w_per_k;
      g(b, a) -= w_per_k;
    }
  };
  for (const NetworkLink& link : n.links) conduct(link.a, link.b, link.w_per_k);
  conduct(n.tec_from, n.tec_to, tec_conductance_w_per_k);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(count);
  e(n.casing_sensor.node) = 1.0;
  const Eigen::VectorXd t = g.partialPivLu().solve(e);
  return 1.0 / t(n.casing_sensor.node);
}

double PlantParams::die_tau_s() const noexcept {
  if (!network) return die_capacity_j_per_k / casing_die_w_per_k;
  const ThermalNetwork& n = *network;
  double g = 0.0;
  for (const NetworkLink& link : n.links) {
    if (link.a == n.gyro_node || link.b == n.gyro_node) g += link.w_per_k;
  }
  if (n.tec_from == n.gyro_node || n.tec_to == n.gyro_node) g += tec_conductance_w_per_k;
  return n.nodes[static_cast<std::size_t>(n.gyro_node)].capacity_j_per_k / g;
}

void validate(const PlantParams& p) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  require(positive(p.shell_capacity_j_per_k), "shell_capacity_j_per_k", "must be positive");
  require(positive(p.casing_capacity_j_per_k), "casing_capacity_j_per_k", "must be positive");
  require(positive(p.die_capacity_j_per_k), "die_capacity_j_per_k", "must be positive");
  require(positive(p.shell_ambient_w_per_k), "shell_ambient_w_per_k", "must be positive");
  require(non_negative(p.shell_casing_leak_w_per_k), "shell_casing_leak_w_per_k",
          "must be zero or positive");
  require(positive(p.casing_die_w_per_k), "casing_die_w_per_k", "must be positive");
  require(std::isfinite(p.internal_power_w), "internal_power_w", "must be a number");
  require(non_negative(p.tec_seebeck_v_per_k), "tec_seebeck_v_per_k", "must be zero or positive");
  require(positive(p.tec_resistance_ohm), "tec_resistance_ohm", "must be positive");
  require(non_negative(p.tec_conductance_w_per_k), "tec_conductance_w_per_k",
          "must be zero or positive");
  require(positive(p.dac_vref_v), "dac_vref_v", "must be positive");
  require(p.dac_bits >= 1 && p.dac_bits <= 24, "dac_bits", "must be within 1..24");
  require(positive(p.gain_a_per_v), "gain_a_per_v", "must be positive");
  require(positive(p.current_limit_a), "current_limit_a", "must be positive");
  require(std::isfinite(p.supply_pos_v) && std::isfinite(p.supply_neg_v) &&
              p.supply_neg_v < p.supply_pos_v,
          "supply_neg_v", "must be below supply_pos_v");
  require(non_negative(p.rail_headroom_v) &&
              2.0 * p.rail_headroom_v < p.supply_pos_v - p.supply_neg_v,
          "rail_headroom_v", "must leave an output range between the rails");
  require(non_negative(p.opa548_theta_ja_c_per_w), "opa548_theta_ja_c_per_w",
          "must be zero or positive");
  require(positive(p.opa548_thermal_tau_s), "opa548_thermal_tau_s", "must be positive");
  require(std::isfinite(p.opa548_restart_c) && std::isfinite(p.opa548_shutdown_c) &&
              p.opa548_restart_c < p.opa548_shutdown_c,
          "opa548_restart_c", "must be below opa548_shutdown_c");
  require(std::isfinite(p.ds18b20_offset_c), "ds18b20_offset_c", "must be a number");
  require(positive(p.scale_mv_per_dps), "scale_mv_per_dps", "must be positive");
  require(std::isfinite(p.zero_rate_offset_mv), "zero_rate_offset_mv", "must be a number");
  require(non_negative(p.arw_deg_per_sqrt_h), "arw_deg_per_sqrt_h", "must be zero or positive");
  require(non_negative(p.bias_instability_dps), "bias_instability_dps", "must be zero or positive");
  require(positive(p.bias_instability_tau_s), "bias_instability_tau_s", "must be positive");
  require(non_negative(p.adc_noise_uv), "adc_noise_uv", "must be zero or positive");
  require(positive(p.max_thermal_step_s), "max_thermal_step_s", "must be positive");
  require(std::isfinite(p.initial_temp_c) && p.initial_temp_c > -kKelvin, "initial_temp_c",
          "must be a temperature above absolute zero");
  if (p.network) validate(*p.network);
}

Plant::Plant(const PlantParams& params, std::uint64_t seed)
    : params_(params),
      random_(seed),
      effects_(params.effects),
      ambient_c_(params.initial_temp_c),
      shell_c_(params.initial_temp_c),
      casing_c_(params.initial_temp_c),
      die_c_(params.initial_temp_c),
      tec_from_c_(params.initial_temp_c),
      tec_to_c_(params.initial_temp_c),
      controlled_c_(params.initial_temp_c),
      sensor_c_(params.initial_temp_c),
      ambient_sensor_c_(params.initial_temp_c),
      casing_lag_c_(params.initial_temp_c),
      ambient_lag_c_(params.initial_temp_c),
      // Its own stream: a sensor's noise must not change the gyro's.
      sensor_random_(seed ^ 0x5e45'0a7d'd5b1'8b20ULL),
      dac_lsb_v_(0.0),
      opa548_junction_c_(params.initial_temp_c) {
  validate(params_);
  network_ = params_.network.has_value();
  if (network_) {
    const std::size_t n = params_.network->nodes.size();
    node_c_.assign(n, params_.initial_temp_c);
    matrix_.assign(n * n, 0.0);
    rhs_.assign(n, 0.0);
    controlled_c_ += params_.network->casing_sensor.offset_c;
  }
  update_sensors(0.0);
  dac_lsb_v_ = params_.dac_vref_v / std::ldexp(1.0, params_.dac_bits);
  effects_.reset(die_c_);
  effects_.set_ambient_c(ambient_c_);
  update_bias();
}

double stage_current_a(const PlantParams& params, double dac_v) noexcept {
  return (dac_v - 0.5 * params.dac_vref_v) * params.gain_a_per_v;
}

double stage_drive_v(const PlantParams& params, double current_a) noexcept {
  return 0.5 * params.dac_vref_v + current_a / params.gain_a_per_v;
}

void Plant::set_tec_drive_v(double dac_v) noexcept {
  if (!std::isfinite(dac_v)) dac_v = 0.5 * params_.dac_vref_v;
  // AD5060: code = V / LSB, straight binary 0 .. 2^N - 1.
  const double max_code = std::ldexp(1.0, params_.dac_bits) - 1.0;
  const double code = std::clamp(std::round(dac_v / dac_lsb_v_), 0.0, max_code);
  const double out_v = code * dac_lsb_v_;
  tec_command_a_ = stage_current_a(params_, out_v);
  update_stage();
}

void Plant::set_tec_enabled(bool enabled) noexcept {
  tec_enabled_ = enabled;
  update_stage();
}

void Plant::update_stage() noexcept {
  if (!tec_enabled_ || opa548_shutdown_) {
    tec_current_a_ = 0.0;
    tec_limited_ = false;
    return;
  }
  const double s = params_.tec_seebeck_v_per_k;
  const double r = params_.tec_resistance_ohm;
  const double seebeck_v = s * (tec_to_c_ - tec_from_c_);
  // OPA548 output swing: V = S dT + I R must stay headroom away from each rail.
  const double v_hi = params_.supply_pos_v - params_.rail_headroom_v;
  const double v_lo = params_.supply_neg_v + params_.rail_headroom_v;
  const double i_hi = std::min(params_.current_limit_a, (v_hi - seebeck_v) / r);
  const double i_lo = std::max(-params_.current_limit_a, (v_lo - seebeck_v) / r);
  tec_current_a_ = std::clamp(tec_command_a_, std::min(i_lo, i_hi), std::max(i_lo, i_hi));
  tec_limited_ = tec_current_a_ != tec_command_a_;
}

double Plant::tec_voltage_v() const noexcept {
  // Open circuit (OPA548 off) the module still shows its Seebeck voltage.
  return params_.tec_seebeck_v_per_k * (tec_to_c_ - tec_from_c_) + tec_current_a_ * params_.tec_resistance_ohm;
}

void Plant::advance(double dt_s) noexcept {
  if (!(dt_s > 0.0) || !std::isfinite(dt_s)) return;
  pending_s_ += dt_s;
  if (pending_s_ >= params_.max_thermal_step_s * (1.0 - 1e-9)) flush();
}

void Plant::flush() noexcept {
  if (!(pending_s_ > 0.0)) return;
  const double steps = std::ceil(pending_s_ / params_.max_thermal_step_s - 1e-9);
  const long n = std::max(1L, static_cast<long>(steps));
  const double h = pending_s_ / static_cast<double>(n);
  for (long k = 0; k < n; ++k) step_thermal(h);
  thermal_time_s_ += pending_s_;
  pending_s_ = 0.0;
}

void Plant::step_thermal(double h) noexcept {
  update_stage();
  const auto& p = params_;
  const double i = tec_current_a_;
  if (network_) {
    step_network(h, i);
  } else {
    step_default_network(h, i);
  }
  update_sensors(h);

  // OPA548 junction: dissipation between the active rail and the load.
  const double v_tec = tec_voltage_v();
  const double p_diss = i >= 0.0 ? (p.supply_pos_v - v_tec) * i : (v_tec - p.supply_neg_v) * -i;
  const double target_c = ambient_c_ + std::max(0.0, p_diss) * p.opa548_theta_ja_c_per_w;
  opa548_junction_c_ += (target_c - opa548_junction_c_) * (1.0 - std::exp(-h / p.opa548_thermal_tau_s));
  if (opa548_junction_c_ >= p.opa548_shutdown_c) opa548_shutdown_ = true;
  if (opa548_junction_c_ <= p.opa548_restart_c) opa548_shutdown_ = false;

  // Bias instability: first-order Gauss-Markov process, exact discretisation.
  const double phi = std::exp(-h / p.bias_instability_tau_s);
  const double sigma_mv = p.bias_instability_dps * p.scale_mv_per_dps;
  instability_mv_ = phi * instability_mv_ + sigma_mv * std::sqrt(1.0 - phi * phi) * random_.normal();

  effects_.set_ambient_c(ambient_c_);
  effects_.advance(h, die_c_);
  update_bias();
}

void Plant::step_default_network(double h, double i) noexcept {
  const auto& p = params_;
  const double si = p.tec_seebeck_v_per_k * i;
  const double joule_half_w = 0.5 * i * i * p.tec_resistance_ohm;
  const double gp = p.tec_conductance_w_per_k + p.shell_casing_leak_w_per_k;
  const double gsa = p.shell_ambient_w_per_k;
  const double gcd = p.casing_die_w_per_k;
  const double cs = p.shell_capacity_j_per_k / h;
  const double cc = p.casing_capacity_j_per_k / h;
  const double cd = p.die_capacity_j_per_k / h;

  // Backward Euler: (C/h - A) T' = C/h T + b, a tridiagonal system in
  // (shell, casing, die).
  const double a00 = cs + gsa + gp + si;
  const double a01 = -gp;
  const double a10 = -gp;
  const double a11 = cc + gp + gcd - si;
  const double a12 = -gcd;
  const double a21 = -gcd;
  const double a22 = cd + gcd;
  const double b0 = cs * shell_c_ + gsa * ambient_c_ - si * kKelvin + joule_half_w;
  const double b1 = cc * casing_c_ + si * kKelvin + joule_half_w + p.internal_power_w +
                    tec_joule_heat_w(p.effects, i);
  const double b2 = cd * die_c_;

  // Eliminate the die row into the casing row, then the casing into the shell.
  const double a11p = a11 - a12 * a21 / a22;
  const double b1p = b1 - a12 * b2 / a22;
  const double a00p = a00 - a01 * a10 / a11p;
  const double b0p = b0 - a01 * b1p / a11p;
  shell_c_ = b0p / a00p;
  casing_c_ = (b1p - a10 * shell_c_) / a11p;
  die_c_ = (b2 - a21 * casing_c_) / a22;
  tec_from_c_ = shell_c_;
  tec_to_c_ = casing_c_;
  controlled_c_ = casing_c_;
}

void Plant::step_network(double h, double i) noexcept {
  const auto& p = params_;
  const ThermalNetwork& net = *p.network;
  const int n = static_cast<int>(node_c_.size());
  double* m = matrix_.data();
  double* b = rhs_.data();
  // Backward Euler: (C/h + G + TEC) T' = C/h T + sources, dense (a few nodes).
  std::fill(matrix_.begin(), matrix_.end(), 0.0);
  for (int r = 0; r < n; ++r) {
    const NetworkNode& node = net.nodes[static_cast<std::size_t>(r)];
    const double c = node.capacity_j_per_k / h;
    m[r * n + r] = c;
    b[r] = c * node_c_[static_cast<std::size_t>(r)] + node.heat_w;
  }
  auto conduct = [&](int a, int bb, double g) {
    if (a != kAmbientNode) m[a * n + a] += g;
    if (bb != kAmbientNode) m[bb * n + bb] += g;
    if (a == kAmbientNode) b[bb] += g * ambient_c_;
    else if (bb == kAmbientNode) b[a] += g * ambient_c_;
    else {
      m[a * n + bb] -= g;
      m[bb * n + a] -= g;
    }
  };
  for (const NetworkLink& link : net.links) conduct(link.a, link.b, link.w_per_k);
  // The TEC (see the header): S I T pumped from the first side into the
  // second, half the Joule heat into each, K conducting between them.
  conduct(net.tec_from, net.tec_to, p.tec_conductance_w_per_k);
  const double si = p.tec_seebeck_v_per_k * i;
  const double joule_half_w = 0.5 * i * i * p.tec_resistance_ohm;
  m[net.tec_from * n + net.tec_from] += si;
  m[net.tec_to * n + net.tec_to] -= si;
  b[net.tec_from] += -si * kKelvin + joule_half_w;
  b[net.tec_to] += si * kKelvin + joule_half_w + tec_joule_heat_w(p.effects, i);

  // Gaussian elimination with partial pivoting, in place.
  for (int k = 0; k < n; ++k) {
    int pivot = k;
    for (int r = k + 1; r < n; ++r) {
      if (std::fabs(m[r * n + k]) > std::fabs(m[pivot * n + k])) pivot = r;
    }
    if (pivot != k) {
      for (int c = k; c < n; ++c) std::swap(m[k * n + c], m[pivot * n + c]);
      std::swap(b[k], b[pivot]);
    }
    for (int r = k + 1; r < n; ++r) {
      const double f = m[r * n + k] / m[k * n + k];
      if (f == 0.0) continue;
      for (int c = k; c < n; ++c) m[r * n + c] -= f * m[k * n + c];
      b[r] -= f * b[k];
    }
  }
  for (int r = n - 1; r >= 0; --r) {
    double sum = b[r];
    for (int c = r + 1; c < n; ++c) sum -= m[r * n + c] * node_c_[static_cast<std::size_t>(c)];
    node_c_[static_cast<std::size_t>(r)] = sum / m[r * n + r];
  }

  tec_from_c_ = node_c(net.tec_from);
  tec_to_c_ = node_c(net.tec_to);
  shell_c_ = tec_from_c_;
  casing_c_ = node_c(net.casing_sensor.node);
  die_c_ = node_c(net.gyro_node);
  controlled_c_ = casing_c_ + net.casing_sensor.offset_c;
}

double Plant::node_c(int i) const noexcept {
  if (i == kAmbientNode) return ambient_c_;
  if (network_) return node_c_[static_cast<std::size_t>(i)];
  return i == 0 ? shell_c_ : i == 1 ? casing_c_ : die_c_;
}

void Plant::update_sensors(double h) noexcept {
  if (!network_) {
    sensor_c_ = casing_c_ + params_.ds18b20_offset_c;
    return;
  }
  const ThermalNetwork& net = *params_.network;
  auto read = [&](const NetworkSensor& s, double& lag_c) {
    const double now_c = node_c(s.node);
    // First-order lag, exact for a temperature held over the step.
    lag_c = s.tau_s > 0.0 ? now_c + (lag_c - now_c) * std::exp(-h / s.tau_s) : now_c;
    return lag_c + s.offset_c + (s.noise_c > 0.0 ? s.noise_c * sensor_random_.normal() : 0.0);
  };
  sensor_c_ = read(net.casing_sensor, casing_lag_c_);
  ambient_sensor_c_ = read(net.ambient_sensor, ambient_lag_c_);
}

void Plant::update_bias() noexcept {
  bias_mv_ = params_.zero_bias.bias_mv(effects_.bias_temp_c()) + params_.zero_rate_offset_mv + effects_.extra_bias_mv();
}

double Plant::gyro_mv(double sample_period_s) noexcept {
  if (sample_period_s != noise_period_s_) {
    noise_period_s_ = sample_period_s;
    const double period = sample_period_s > 0.0 ? sample_period_s : 1.0;
    // ARW (deg/sqrt(h)) -> white rate noise density (deg/s/sqrt(Hz)) = ARW / 60;
    // one sample averages over its period: sigma = density / sqrt(period).
    const double gyro_sigma_mv = params_.scale_mv_per_dps * params_.arw_deg_per_sqrt_h / 60.0 / std::sqrt(period);
    const double adc_sigma_mv = params_.adc_noise_uv * 1e-3;
    noise_sigma_mv_ = std::hypot(gyro_sigma_mv, adc_sigma_mv);
  }
  return bias_mv_ + instability_mv_ + params_.scale_mv_per_dps * rate_dps_ +
         noise_sigma_mv_ * random_.normal();
}

double Plant::drive_frequency_hz() const noexcept { return table1_drive_frequency_hz(die_c_); }
double Plant::drive_q() const noexcept { return table1_drive_q(die_c_); }

}  // namespace gyrotc::model
