#pragma once

#include <limits>
#include <span>

// The thermal model `gyrotc tune` identifies from a unit's own record: the
// plant's structure (model/plant.hpp), written per unit of casing heat
// capacity because a record of temperatures and currents cannot tell the
// absolute heat capacity, only every rate relative to it:
//
//   casing  dTc/dt = a I (Tc + 273.15) + b I^2 - g (Tc - Ts) + p
//   shell   dTs/dt = r [-a I (Ts + 273.15) + b I^2 + g (Tc - Ts)] - e (Ts - Ta)
//
// a = S/Cc (Peltier), b = R/(2 Cc) (Joule heat, half on each side), g =
// G_tec+leak/Cc (conduction through the module and its insulation), p =
// P_internal/Cc, r = Cc/Cs, e = G_shell-ambient/Cs. The shell is described by
// what a record can resolve: the casing's loss to the ambient with the TEC
// off (g_ca = g k/(1+k), k = G_shell-ambient / G_tec+leak) and the shell's
// time constant 1/(r g + e).
//
// The current applied is the command clipped by the OPA548's output swing:
// S (Tc - Ts) + I R within the rails, i.e. I <= rail_a - (S/R)(Tc - Ts) and
// I >= -rail_a - (S/R)(Tc - Ts), with S/R = a/(2b) (rails taken symmetric),
// and by the OPA548's own current limit (its ILIM resistor), |I| <= stage_limit_a,
// which can sit below the limit the board is configured for.
//
// A side node may hang on the casing alone (a board, a lid that takes heat
// from it and gives it back later, and that the sensor does not see):
//
//   casing  ... - h (Tc - Tb)        side  dTb/dt = (Tc - Tb) / tau_b
//
// h = G_side/Cc, tau_b = C_side/G_side. It has no heat source of its own, so it
// changes no steady state, only the casing's approach to one. h = 0: none.
//
// The DS18B20 sees the casing through a first-order lag and a dead time (the
// conversion, the reading's age when a row or a PID period takes it, the
// command's alignment to the rows). The lag's input is (1 - q) Tc + q Ta: a
// sensor on a part of the housing that also loses heat to the room (a lid, a
// board) settles between the casing and the ambient, and follows a change of
// the ambient through its own lag, not through the shell. q = 0: the sensor
// sees the casing alone.
namespace gyrotc::tune {

inline constexpr double kKelvin = 273.15;

struct ThermalModel {
  double peltier_per_a_s = 1.7e-4;     // a = S / Cc, 1/(A s)
  double joule_k_per_a2_s = 0.02;      // b = R / (2 Cc), K/(A^2 s)
  double loss_per_s = 3e-4;            // g_ca: casing to ambient with the TEC off, per Cc, 1/s
  double shell_ratio = 5.7;            // k = G_shell-ambient / G_tec+leak
  double shell_tau_s = 77.0;           // 1 / (r g + e), s
  double internal_k_per_s = 1e-3;      // p = P_internal / Cc, K/s
  double dead_time_s = 1.0;
  double sensor_lag_s = 0.0;
  double sensor_ambient_share = 0.0;   // q: the ambient's share in what the sensor's lag follows
  double rail_a = 1e3;                 // OPA548 swing / R: the current at Tc = Ts; large = never clips
  double stage_limit_a = 1e3;          // OPA548 ILIM, A; large = never clips
  double side_per_s = 0.0;             // h = G_side / Cc, 1/s; 0 = no side node
  double side_tau_s = 100.0;           // tau_b = C_side / G_side, s

  // Derived rates.
  double casing_shell_per_s() const noexcept;  // g
  double capacity_ratio() const noexcept;      // r = Cc / Cs
  double shell_ambient_per_s() const noexcept; // e
  double rail_a_per_c() const noexcept;        // S / R = a / (2 b)

  // The sensor's steady reading with the casing at casing_c, and its inverse.
  double steady_reading_c(double casing_c, double ambient_c) const noexcept;
  double casing_for_reading_c(double reading_c, double ambient_c) const noexcept;
};

struct ThermalState {
  double casing_c = 0.0;
  double shell_c = 0.0;
  double side_c = kAtCasing;  // the side node; kAtCasing (NaN): at the casing's temperature
  static constexpr double kAtCasing = std::numeric_limits<double>::quiet_NaN();
};

// The network with current_a applied (no clipping) at ambient_c, linear in
// the state: d/dt (Tc, Ts) = A (Tc, Ts) + b; without the side node, which
// changes no steady state.
struct ThermalMatrix {
  double a11, a12, a21, a22;
  double b1, b2;
};
ThermalMatrix thermal_matrix(const ThermalModel& m, double current_a, double ambient_c) noexcept;

// The current the stage applies for a command in this state (rail clipping).
double applied_current_a(const ThermalModel& m, const ThermalState& x, double command_a) noexcept;

// dTc/dt per ampere at this state and current (the TEC's small-signal gain
// into the casing, K/(A s)).
double casing_gain_k_per_a_s(const ThermalModel& m, const ThermalState& x, double current_a) noexcept;

// One step of h_s with the command held and the ambient at ambient_c
// (trapezoidal rule; the current is clipped at the step's start).
ThermalState step(const ThermalModel& m, const ThermalState& x, double command_a, double ambient_c,
                  double h_s) noexcept;

// The steady state with `current_a` applied (no clipping) at ambient_c.
ThermalState steady_state(const ThermalModel& m, double current_a, double ambient_c) noexcept;

// The current that holds the sensor's steady reading at reading_c at
// ambient_c (on the heating side of the maximum cooling current); NaN when no
// current within +/- limit_a does, or the stage's rails do not allow it.
double holding_current_a(const ThermalModel& m, double reading_c, double ambient_c, double limit_a) noexcept;

// The DS18B20's view of the housing along a record: the model started in
// `initial` at time_s[0], command_a[k] applied from time_s[k] to
// time_s[k + 1], ambient_c[k] the ambient at time_s[k]. Writes the modelled
// reading at every time_s[k] into sensor_c (same length as time_s). scratch
// must hold time_s.size() values (the lag's output before the dead time).
void simulate_sensor(const ThermalModel& m, const ThermalState& initial, std::span<const double> time_s,
                     std::span<const double> command_a, std::span<const double> ambient_c,
                     std::span<double> sensor_c, std::span<double> scratch) noexcept;

}  // namespace gyrotc::tune
