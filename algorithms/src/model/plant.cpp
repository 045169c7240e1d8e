#include "gyrotc/algorithms/model/plant.hpp"

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

double PlantParams::casing_ambient_w_per_k() const noexcept {
  const double parallel = tec_conductance_w_per_k + shell_casing_leak_w_per_k;
  return 1.0 / (1.0 / shell_ambient_w_per_k + 1.0 / parallel);
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
}

Plant::Plant(const PlantParams& params, std::uint64_t seed)
    : params_(params),
      random_(seed),
      effects_(params.effects),
      ambient_c_(params.initial_temp_c),
      shell_c_(params.initial_temp_c),
      casing_c_(params.initial_temp_c),
      die_c_(params.initial_temp_c),
      dac_lsb_v_(0.0),
      opa548_junction_c_(params.initial_temp_c) {
  validate(params_);
  dac_lsb_v_ = params_.dac_vref_v / std::ldexp(1.0, params_.dac_bits);
  effects_.reset(die_c_);
  effects_.set_ambient_c(ambient_c_);
  update_bias();
}

void Plant::set_tec_drive_v(double dac_v) noexcept {
  if (!std::isfinite(dac_v)) dac_v = 0.5 * params_.dac_vref_v;
  // AD5060: code = V / LSB, straight binary 0 .. 2^N - 1.
  const double max_code = std::ldexp(1.0, params_.dac_bits) - 1.0;
  const double code = std::clamp(std::round(dac_v / dac_lsb_v_), 0.0, max_code);
  const double out_v = code * dac_lsb_v_;
  tec_command_a_ = (out_v - 0.5 * params_.dac_vref_v) * params_.gain_a_per_v;
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
  const double seebeck_v = s * (casing_c_ - shell_c_);
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
  return params_.tec_seebeck_v_per_k * (casing_c_ - shell_c_) +
         tec_current_a_ * params_.tec_resistance_ohm;
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
