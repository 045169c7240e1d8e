#include "gyrotc/algorithms/model/effects.hpp"

#include <cmath>

namespace gyrotc::model {

bool Effects::any() const noexcept { return any_on_gyro() || tec_joule_heating.has_value(); }

bool Effects::any_on_gyro() const noexcept {
  return thermal_lag || rate_sensitivity || ramp_hysteresis || warm_up || linear_drift || ambient_sensitivity;
}

double tec_joule_heat_w(const Effects& effects, double tec_a) noexcept {
  if (!effects.tec_joule_heating) return 0.0;
  return 0.5 * tec_a * tec_a * effects.tec_joule_heating->r_ohm;
}

GyroEffectState::GyroEffectState(const Effects& effects) noexcept : effects_(effects) {}

void GyroEffectState::reset(double temp_c) noexcept {
  time_s_ = 0.0;
  temp_c_ = temp_c;
  die_c_ = temp_c;
  rate_c_per_s_ = 0.0;
}

void GyroEffectState::advance(double dt_s, double temp_c) noexcept {
  if (!(dt_s > 0.0)) return;
  const double rate = (temp_c - temp_c_) / dt_s;
  if (effects_.thermal_lag && effects_.thermal_lag->tau_s > 0.0) {
    // Exact solution of dT_die/dt = (T - T_die)/tau for T linear over the
    // step, so any step size is stable and accurate.
    const double tau = effects_.thermal_lag->tau_s;
    const double decay = std::exp(-dt_s / tau);
    die_c_ = temp_c - rate * tau + (die_c_ - temp_c_ + rate * tau) * decay;
  } else {
    die_c_ = temp_c;
  }
  temp_c_ = temp_c;
  rate_c_per_s_ = rate;
  time_s_ += dt_s;
}

double GyroEffectState::bias_temp_c() const noexcept {
  return effects_.thermal_lag ? die_c_ : temp_c_;
}

double GyroEffectState::extra_bias_mv() const noexcept {
  double mv = 0.0;
  if (effects_.rate_sensitivity) mv += effects_.rate_sensitivity->k_mv_per_c_per_s * rate_c_per_s_;
  if (effects_.ramp_hysteresis && effects_.ramp_hysteresis->r0_c_per_s > 0.0) {
    mv += effects_.ramp_hysteresis->h_mv *
          std::tanh(rate_c_per_s_ / effects_.ramp_hysteresis->r0_c_per_s);
  }
  if (effects_.warm_up && effects_.warm_up->tau_s > 0.0) {
    mv += effects_.warm_up->a_mv * std::exp(-time_s_ / effects_.warm_up->tau_s);
  }
  if (effects_.linear_drift) mv += effects_.linear_drift->d_mv_per_h * time_s_ / 3600.0;
  if (effects_.ambient_sensitivity) {
    mv += effects_.ambient_sensitivity->k_mv_per_c * (ambient_c_ - effects_.ambient_sensitivity->ref_c);
  }
  return mv;
}

}  // namespace gyrotc::model
