#pragma once

#include <array>
#include <optional>
#include <string_view>

// The named effect library of the discrepancy workflow (`gyrotc identify`,
// issue 8). Each effect is a physical mechanism the base plant lacks; the
// names and parameter names are part of the interface (CLI verdicts, JSON,
// the `[effects.<name>]` tables of a plant description). An effect is on when
// its std::optional holds a value.
//
// On gyro_mv, with T the temperature the bias curve is evaluated at in the
// base model (the temperature the DS18B20 reads) and t the time since
// power-on:
//   thermal_lag       dT_die/dt = (T - T_die)/tau_s, bias evaluated at T_die
//   rate_sensitivity  bias += k_mv_per_c_per_s * dT/dt
//   ramp_hysteresis   bias += h_mv * tanh((dT/dt) / r0_c_per_s)
//   warm_up           bias += a_mv * exp(-t / tau_s)      (seed Section 3, Figure 9)
//   linear_drift      bias += d_mv_per_h * t / 3600
//   ambient_sensitivity bias += k_mv_per_c * (T_ambient - ref_c): a readout
//                     (or package stress) that follows the surroundings
//                     rather than the casing the TEC controls
// On the casing heat balance:
//   tec_joule_heating the casing receives I^2 * r_ohm / 2 (half the TEC's
//                     Joule heat) in addition to the base model's heat flows.
namespace gyrotc::model {

struct ThermalLagEffect {
  double tau_s = 120.0;
};
struct RateSensitivityEffect {
  double k_mv_per_c_per_s = 0.0;
};
struct RampHysteresisEffect {
  double h_mv = 0.0;
  double r0_c_per_s = 0.005;
};
struct WarmUpEffect {
  double a_mv = 0.0;
  double tau_s = 600.0;
};
struct LinearDriftEffect {
  double d_mv_per_h = 0.0;
};
// Reference ambient of ambient_sensitivity: where it adds nothing.
inline constexpr double kAmbientReferenceC = 25.0;
struct AmbientSensitivityEffect {
  double k_mv_per_c = 0.0;
  double ref_c = kAmbientReferenceC;
};
struct TecJouleHeatingEffect {
  double r_ohm = 0.0;
};

struct Effects {
  std::optional<ThermalLagEffect> thermal_lag;
  std::optional<RateSensitivityEffect> rate_sensitivity;
  std::optional<RampHysteresisEffect> ramp_hysteresis;
  std::optional<WarmUpEffect> warm_up;
  std::optional<LinearDriftEffect> linear_drift;
  std::optional<AmbientSensitivityEffect> ambient_sensitivity;
  std::optional<TecJouleHeatingEffect> tec_joule_heating;

  bool any() const noexcept;
  bool any_on_gyro() const noexcept;
};

// The names as they appear in verdicts and plant files, in library order.
inline constexpr std::array<std::string_view, 7> kTimeSeriesEffectNames = {
    "thermal_lag", "rate_sensitivity", "ramp_hysteresis",     "warm_up",
    "linear_drift", "ambient_sensitivity", "tec_joule_heating"};

// Heat (W) the tec_joule_heating effect adds to the casing at TEC current
// tec_a: I^2 R / 2; 0 when the effect is off.
double tec_joule_heat_w(const Effects& effects, double tec_a) noexcept;

// Evaluates the gyro_mv effects along one run. The plant calls reset() at
// power-on and advance() after each step with the temperature reached; it
// then evaluates its bias curve at bias_temp_c() and adds extra_bias_mv().
// No allocation, no throw: safe on the simulation's sample path.
class GyroEffectState {
 public:
  explicit GyroEffectState(const Effects& effects) noexcept;

  // Power-on: t = 0, the die at temp_c, no temperature rate.
  void reset(double temp_c) noexcept;
  // The ambient (chamber) temperature now; until set, ambient_sensitivity
  // sees its reference (adds nothing).
  void set_ambient_c(double ambient_c) noexcept { ambient_c_ = ambient_c; }
  // The run advanced by dt_s and the temperature is now temp_c. dT/dt is the
  // step's finite difference (the plant's temperature is noise-free).
  void advance(double dt_s, double temp_c) noexcept;

  double time_s() const noexcept { return time_s_; }
  double temp_c() const noexcept { return temp_c_; }
  double rate_c_per_s() const noexcept { return rate_c_per_s_; }
  // T_die with thermal_lag on, else the temperature itself.
  double bias_temp_c() const noexcept;
  // Sum of the additive terms (rate_sensitivity, ramp_hysteresis, warm_up,
  // linear_drift, ambient_sensitivity), mV.
  double extra_bias_mv() const noexcept;

 private:
  Effects effects_;
  double time_s_ = 0.0;
  double temp_c_ = 0.0;
  double die_c_ = 0.0;
  double rate_c_per_s_ = 0.0;
  double ambient_c_ = kAmbientReferenceC;
};

}  // namespace gyrotc::model
