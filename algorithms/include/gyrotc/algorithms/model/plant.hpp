#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "gyrotc/algorithms/model/effects.hpp"
#include "gyrotc/algorithms/model/gyro_bias_curve.hpp"
#include "gyrotc/algorithms/model/random.hpp"
#include "gyrotc/algorithms/model/thermal_network.hpp"

// The physical plant of the seed's temperature-controlled gyroscope (Section 6):
// a chamber (ambient) around an outer shell, a Peltier TEC wall-embedded in that
// shell (Section 6.2: "The thermoelectric cooler (TEC) is wall-imbedded in the
// outside shell of the gyroscope"), the inner housing (the casing, where the
// DS18B20 sits) and the sensing element (the gyro die) inside it.
//
//   ambient --G_sa-- shell ==TEC(S, R, K) + G_leak== casing --G_cd-- die
//                                                      ^ P_internal
//
// Heat balance (temperatures in kelvin in the Seebeck terms, I > 0 heats the casing):
//   into casing from the TEC  Q_c =  S I T_c + I^2 R / 2 + K (T_s - T_c)
//   into shell from the TEC   Q_s = -S I T_s + I^2 R / 2 + K (T_c - T_s)
//   electrical                V = S (T_c - T_s) + I R,   Q_c + Q_s = V I.
// With I held between control updates the network is linear in temperature;
// it is integrated with backward Euler (L-stable: any step is stable, a stiff
// die cannot blow up) on steps of at most max_thermal_step_s.
//
// Every default below is a documented physical choice; docs/GUIDE.md "Simulation"
// explains the calibration against the seed's Fig. 26.
namespace gyrotc::model {

struct PlantParams {
  // --- thermal network -----------------------------------------------------
  // Outer shell: ~60 g of aluminium 6061 (c = 0.896 J/(g K)) -> 54 J/K.
  double shell_capacity_j_per_k = 54.0;
  // Inner housing (casing) with the gyro PCB and drive electronics: ~290 g of
  // aluminium plus ~40 g of FR-4 (c = 1.1 J/(g K)) -> ~300 J/K. Sets the
  // warm-up time of Fig. 26 (about 900 s from 16 C to 55 C).
  double casing_capacity_j_per_k = 300.0;
  // Gyro die in its ceramic package (~2 g of alumina/silicon, c ~ 0.8 J/(g K)).
  double die_capacity_j_per_k = 1.6;
  // Chamber air to shell: forced convection in a temperature box,
  // h ~ 20 W/(m^2 K) over ~0.02 m^2 of shell surface (0.4 W/K), plus
  // conduction into the mounting fixture (~0.2 W/K).
  double shell_ambient_w_per_k = 0.6;
  // Shell to casing in parallel with the TEC: insulation foam, standoffs and
  // cables (a few nylon standoffs and ~10 mm of PU foam): 0.02 W/K.
  double shell_casing_leak_w_per_k = 0.02;
  // Casing to die through the package and PCB: tau_die = C_die / G = 40 s
  // (an assumption: no die time constant is given by the seed).
  double casing_die_w_per_k = 0.04;
  // Constant heat released inside the casing by the drive and sense
  // electronics (seed Section 3, Figure 9: the drive circuit warms up).
  double internal_power_w = 0.3;

  // --- TEC (datasheet-style module parameters at 300 K) --------------------
  // A 127-couple Bi2Te3 module with long, thin legs (the Imax ~1.3 A class):
  // S = 2 N alpha = 127 * 2 * 200 uV/K = 0.051 V/K, R = 12 Ohm, K = 0.085 W/K;
  // consistent with Z = S^2 / (R K) = 2.6e-3 1/K (ZT ~ 0.8, typical Bi2Te3)
  // and Imax = S T / R ~ 1.3 A. A low-K module is what lets the seed's PD
  // phase (Kp = 0.48 A/C) enter the 0.5 C integration band: at 16 C ambient
  // it holds 55 C with ~0.2 A, i.e. a PD offset of ~0.4 C.
  double tec_seebeck_v_per_k = 0.051;
  double tec_resistance_ohm = 12.0;
  double tec_conductance_w_per_k = 0.085;

  // --- TEC stage: AD5060 #2 into the OPA548 (current mode) -----------------
  double dac_vref_v = 5.0;  // AD5060 reference (VDD = 5 V)
  int dac_bits = 16;        // AD5060: 16-bit straight binary
  // I = (V_dac - V_ref/2) * gain: mid-scale is 0 A.
  double gain_a_per_v = 1.0;
  // OPA548 current limit (set by its ILIM resistor; the part allows up to
  // 5 A): 1 A, below the module's Imax.
  double current_limit_a = 1.0;
  // OPA548 supply rails (+/-15 V, bipolar as in seed Section 6.1) and output
  // swing to each rail (datasheet: about 2.5 V of headroom at 1-3 A).
  double supply_pos_v = 15.0;
  double supply_neg_v = -15.0;
  double rail_headroom_v = 2.5;
  // OPA548 junction: TO-220 on a small heat sink, theta_JA ~ 6 C/W, thermal
  // time constant of the sink ~30 s; thermal shutdown at 160 C junction,
  // restarts 15 C lower (the datasheet's typical hysteresis).
  double opa548_theta_ja_c_per_w = 6.0;
  double opa548_thermal_tau_s = 30.0;
  double opa548_shutdown_c = 160.0;
  double opa548_restart_c = 145.0;

  // --- sensors and the gyro --------------------------------------------------
  // DS18B20 offset from the casing temperature (datasheet accuracy +/-0.5 C
  // from -10 to +85 C; 0 = an ideal part).
  double ds18b20_offset_c = 0.0;
  // Seed Table 2 note: scale factor 8.774 mV/(deg/s).
  double scale_mv_per_dps = 8.774;
  // Angle random walk and bias instability: not given by the seed; typical of
  // a 2009 vibratory MEMS gyro of this class (assumptions, documented).
  double arw_deg_per_sqrt_h = 1.0;
  double bias_instability_dps = 0.01;
  double bias_instability_tau_s = 100.0;
  // This unit's zero-rate output against the seed's part (Table 2): parts
  // of one type differ by tens of mV, which is why each unit is calibrated
  // (seed Section 4). 0 = the seed's own gyro.
  double zero_rate_offset_mv = 0.0;
  // The zero-rate output against the die temperature (before the offset
  // above): the seed's Table 2 unless the plant file gives another.
  ZeroBiasCurve zero_bias;
  // ADS1251 input-referred noise (datasheet: ~1.5 uV rms at 20 kSPS-class
  // settings; negligible next to the gyro's own noise).
  double adc_noise_uv = 1.5;

  // --- integration -----------------------------------------------------------
  // The thermal network advances in steps of at most this (backward Euler).
  // Time given to advance() is accumulated until it reaches this step, so the
  // per-sample path stays cheap; the thermal state lags the plant's clock by
  // less than one step.
  double max_thermal_step_s = 0.1;
  // Every node starts at this temperature (the chamber at power-on).
  double initial_temp_c = 16.0;

  // Named effects of the discrepancy workflow (off by default).
  Effects effects;

  // The user's own housing (thermal_network.hpp). When set it replaces the
  // three-node network above: the shell/casing/die capacities and
  // conductances, internal_power_w and ds18b20_offset_c are not used.
  std::optional<ThermalNetwork> network;

  // Conductance from the casing sensor's node to the ambient with the TEC
  // off (its conductance K still conducts), W/K: the series shell path of the
  // default network, the network's steady-state response otherwise.
  double casing_ambient_w_per_k() const;
  // The die's own time constant against the node it hangs on, s.
  double die_tau_s() const noexcept;
};

// Throws std::invalid_argument naming the field when a parameter is not
// physical (non-positive capacity or conductance, limits out of order, ...).
void validate(const PlantParams& params);

// The OPA548 stage's law, mid-scale = 0 A: the current an AD5060 output
// commands (before the stage's limits), and the output that commands a
// current (before the DAC's code grid). Plant::set_tec_drive_v applies the first.
double stage_current_a(const PlantParams& params, double dac_v) noexcept;
double stage_drive_v(const PlantParams& params, double current_a) noexcept;

class Plant {
 public:
  Plant(const PlantParams& params, std::uint64_t seed);

  // --- inputs -----------------------------------------------------------------
  void set_ambient_c(double ambient_c) noexcept { ambient_c_ = ambient_c; }
  // AD5060 #2 output volts; the OPA548 stage maps it to TEC current, mid-scale
  // = 0 A. The value is quantised to the DAC's code grid.
  void set_tec_drive_v(double dac_v) noexcept;
  // OPA548 E/S: false = output disabled (0 A).
  void set_tec_enabled(bool enabled) noexcept;
  // The true angular rate applied to the gyro.
  void set_rate_dps(double rate_dps) noexcept { rate_dps_ = rate_dps; }

  // Advance the plant by dt_s (any dt >= 0; stable for any step).
  void advance(double dt_s) noexcept;
  // Integrate any time accumulated below one thermal step.
  void flush() noexcept;

  // --- state ------------------------------------------------------------------
  double time_s() const noexcept { return thermal_time_s_ + pending_s_; }
  double thermal_time_s() const noexcept { return thermal_time_s_; }
  double ambient_c() const noexcept { return ambient_c_; }
  // The TEC's first side (the shell of the default network).
  double shell_c() const noexcept { return tec_from_c_; }
  // The casing: the casing sensor's node for a network plant.
  double casing_c() const noexcept { return casing_c_; }
  // The gyro die: the gyro's node for a network plant.
  double die_c() const noexcept { return die_c_; }
  // The temperature the loop controls, as a noiseless reading without lag
  // would show it: the casing node for the default network; the casing
  // sensor's node plus that sensor's offset for a network plant.
  double controlled_c() const noexcept { return controlled_c_; }
  // What a perfect-resolution DS18B20 on the casing would read (for a
  // network plant: lagged, offset and with its noise).
  double sensor_c() const noexcept { return sensor_c_; }
  // What the ambient DS18B20 would read.
  double ambient_sensor_c() const noexcept { return network_ ? ambient_sensor_c_ : ambient_c_; }
  // Temperature of network node i (the default network: shell, casing, die).
  double node_c(int i) const noexcept;
  // Actual TEC current (after the current limit, the rails and E/S).
  double tec_current_a() const noexcept { return tec_current_a_; }
  double tec_voltage_v() const noexcept;
  // Current commanded by the DAC (before limits).
  double tec_command_a() const noexcept { return tec_command_a_; }
  bool tec_enabled() const noexcept { return tec_enabled_; }
  // True when the output is limited (current limit or rail).
  bool tec_limited() const noexcept { return tec_limited_; }
  double opa548_junction_c() const noexcept { return opa548_junction_c_; }
  bool opa548_thermal_shutdown() const noexcept { return opa548_shutdown_; }

  // --- gyro -------------------------------------------------------------------
  // One noisy sample of the gyro output at the ADC input (mV), for a sample
  // period sample_period_s (sets the white-noise bandwidth). No allocation.
  double gyro_mv(double sample_period_s) noexcept;
  // The noise-free zero-rate output now (mV): the Table 2 curve at the die
  // temperature plus the named effects plus the bias-instability process.
  double gyro_bias_mv() const noexcept { return bias_mv_ + instability_mv_; }
  // Drive-mode resonant frequency and quality factor at the die temperature
  // (seed Table 1, for reports).
  double drive_frequency_hz() const noexcept;
  double drive_q() const noexcept;

  const PlantParams& params() const noexcept { return params_; }

 private:
  void step_thermal(double h_s) noexcept;
  void step_default_network(double h_s, double tec_a) noexcept;
  void step_network(double h_s, double tec_a) noexcept;
  void update_sensors(double h_s) noexcept;
  void update_stage() noexcept;
  void update_bias() noexcept;

  PlantParams params_;
  Random random_;
  GyroEffectState effects_;
  double ambient_c_;
  double shell_c_;
  double casing_c_;
  double die_c_;
  // Both sides of the TEC, the controlled temperature and the sensors'
  // readings, for either kind of network.
  double tec_from_c_;
  double tec_to_c_;
  double controlled_c_;
  double sensor_c_;
  double ambient_sensor_c_;
  // A network plant's state: node temperatures, the sensors' lagged
  // temperatures, their noise (its own stream, so that sensor noise leaves
  // the gyro's noise unchanged) and the solver's workspace.
  bool network_ = false;
  std::vector<double> node_c_;
  std::vector<double> matrix_;
  std::vector<double> rhs_;
  double casing_lag_c_;
  double ambient_lag_c_;
  Random sensor_random_;
  double thermal_time_s_ = 0.0;
  double pending_s_ = 0.0;
  double rate_dps_ = 0.0;
  double dac_lsb_v_;
  double tec_command_a_ = 0.0;
  double tec_current_a_ = 0.0;
  bool tec_enabled_ = false;
  bool tec_limited_ = false;
  double opa548_junction_c_;
  bool opa548_shutdown_ = false;
  double bias_mv_ = 0.0;
  double instability_mv_ = 0.0;
  double noise_period_s_ = -1.0;
  double noise_sigma_mv_ = 0.0;
};

}  // namespace gyrotc::model
