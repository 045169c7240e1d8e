#pragma once

#include <cstdint>
#include <optional>

#include "gyrotc/app/runtime/controller_flags.hpp"
#include "gyrotc/hal/temperature_sensor.hpp"

// The Controller's fault supervisor: what the readings, the ADC's samples,
// the OPA548 and the TEC path say of the board, as flags (temp_stale,
// temp_invalid, temp_stuck, over_temp_latched, opa548_thermal, adc_stalled,
// tec_write_failed, ambient_stale, loop_runaway), and the casing and ambient readings the TEC loop may
// use. It decides nothing about the current: the Controller reads its flags.
namespace gyrotc::app {

// Fail-safe limits (issue 6). Defaults are documented choices.
struct FailSafeLimits {
  // A casing reading older than this many PID periods is stale (issue 6: 3).
  double stale_periods = 3.0;
  // Stuck: the reading has not changed for stuck_s while the TEC drove with
  // |I| >= stuck_min_drive_a all along, or while the command swung over at
  // least stuck_span_a. A healthy sensor moves by one 0.0625 C step within
  // minutes at such drive; holding 55 C at -30 C ambient needs ~0.45 A, so a
  // steady hold does not trip it.
  double stuck_s = 300.0;
  double stuck_min_drive_a = 0.5;
  double stuck_span_a = 0.3;
  // Stuck, from the model-based loop's own model (issue 75, item 3): the
  // reading, unchanged, lies more than stuck_sigma standard deviations
  // beyond two steps of where the loop's filter, run on without it since it
  // last changed, puts it (control::ObserverLoop::reading_surprise), at every
  // period for stuck_sigma_s. It replaces the command's swing
  // (stuck_span_a): that loop swings its current to hold a reading on one
  // step through a chamber's ramp (the suite's oracle: a reading unchanged
  // for 6000 s from -14 to 45 C). With the PID the drive criteria above apply.
  double stuck_sigma = 4.0;
  double stuck_sigma_s = 10.0;
  // And actively (runtime/stuck_probe.hpp): a reading the model-based loop
  // held on one step for stuck_probe_s is probed past the step's edges, for
  // stuck_probe_hold_s each; one that follows neither is stuck. 0: off.
  double stuck_probe_s = 0.0;
  double stuck_probe_hold_s = 60.0;
  // Runaway: the model-based loop's command has pushed the reading away from
  // the setpoint (heating above it, cooling below it) at every period for
  // runaway_s, and the reading has moved at least runaway_c further away
  // meanwhile. No model need be right for this to be wrong: the PID takes
  // over (its integral turns towards the setpoint whatever the housing). A
  // loop braking on its way to the setpoint opposes the error too, but the
  // reading comes closer.
  double runaway_s = 120.0;
  double runaway_c = 1.0;
  // Consecutive good readings that clear a stale/invalid/stuck fault.
  int recovery_readings = 3;
  // Casing over-temperature: latched off (the DS18B20 itself goes to 125 C).
  double over_temp_c = 80.0;
  // After an OPA548 thermal flag the TEC stays off this long before it is
  // retried: with E/S released the flag can only be seen while enabled, so a
  // disabled part reads "no fault" whether or not its junction has cooled.
  double opa548_cooldown_s = 60.0;
  // No ADC sample for this long (DRDY never falls, every read fails): the
  // converter or its clock is dead, and with it the unit's rate output. The
  // temperature loop goes on: it needs neither the ADC nor the rate DAC, and
  // a fault the TEC path shares (supply, SPI) shows as its own
  // tec_write_failed or a sensor fault.
  double adc_stall_s = 10.0;
  // No valid ambient reading for this long (the ambient sensor converts every
  // kAmbientEveryReadings-th sensor cycle, about 10.5 s: two missed; one
  // glitch is no fault): the loop goes on with the last one (its
  // feed-forward, the model-based loop's input), flagged.
  double ambient_stale_s = 25.0;
  // Plausible casing range; outside it a reading is invalid (DS18B20: -55..125 C).
  double min_valid_c = -55.0;
  double max_valid_c = 125.0;
};

class FaultSupervisor {
 public:
  static constexpr std::uint32_t kTempFaults = kFlagTempStale | kFlagTempInvalid | kFlagTempStuck;

  explicit FaultSupervisor(const FailSafeLimits& limits) noexcept : limits_(limits) {}

  // An ADC sample came at now_s.
  void on_sample(double now_s) noexcept;
  // A casing reading: true when it is plausible, and so the casing's temperature.
  bool on_temperature(const hal::TemperatureReading& reading, double now_s) noexcept;
  // An ambient reading: when plausible, the time since the last plausible
  // one (0 for the first); nothing otherwise.
  std::optional<double> on_ambient_temperature(const hal::TemperatureReading& reading, double now_s) noexcept;
  void on_opa548_thermal(bool in_shutdown, double now_s) noexcept;
  // Whether the TEC path took the period's command.
  void on_tec_write(bool ok) noexcept;
  // The current the period's command drives (0 while off): the stuck check's evidence.
  void record_command(double current_a) noexcept;
  // The model-based loop's verdict on the period's casing reading (its
  // surprise; 0 when the loop did not check one): the model's stuck check.
  void on_reading_check(double surprise, double now_s) noexcept;
  // The active probe found the reading following neither edge.
  void on_probe_failed() noexcept;
  // The period's command of the model-based loop (model_drove; false: the
  // PID, a programme, or off) against the setpoint it held: the runaway check.
  void on_loop_command(bool model_drove, double current_a, double setpoint_c, double now_s) noexcept;
  // A new model-based loop (a reload): the runaway verdict was the old one's.
  void clear_loop_runaway() noexcept;
  // How long the casing reading has not changed (0 without one).
  double reading_unchanged_s(double now_s) const noexcept { return have_casing_ ? now_s - changed_at_s_ : 0.0; }
  // Whether the loop checks its readings so (the model-based loop does).
  void set_model_check(bool on) noexcept { model_check_ = on; }
  // Every PID period, before the command: the stale, stuck and stall checks.
  void on_tick(double now_s, double period_s) noexcept;
  // Whether a valid casing reading came since the last call (one a period).
  bool take_new_reading() noexcept;

  std::uint32_t flags() const noexcept { return flags_; }
  bool have_casing() const noexcept { return have_casing_; }
  double casing_c() const noexcept { return casing_c_; }
  // When the last valid casing reading was measured.
  double casing_time_s() const noexcept { return casing_time_s_; }
  double ambient_c() const noexcept;  // the last plausible ambient reading, NaN without one

 private:
  // temp_stuck on the current casing reading (false: no reading, or already raised).
  bool raise_stuck() noexcept;

  const FailSafeLimits& limits_;  // the Controller's, fixed for its life
  std::uint32_t flags_ = 0;

  // Casing reading state.
  bool have_casing_ = false;
  double casing_c_ = 0.0;
  double casing_time_s_ = 0.0;   // when the last valid reading was measured
  double changed_at_s_ = 0.0;    // when the value last changed
  int good_streak_ = 0;
  double stuck_value_c_ = 0.0;   // the value that tripped the stuck fault
  bool reading_since_tick_ = false;  // a valid casing reading came since the last tick
  // TEC drive since the reading last changed (for the stuck check).
  double drive_min_abs_a_ = 0.0;
  double drive_lo_a_ = 0.0;
  double drive_hi_a_ = 0.0;
  bool model_check_ = false;
  bool surprised_ = false;          // the model's check failed at every period since surprised_since_s_
  double surprised_since_s_ = 0.0;
  bool opposing_ = false;           // the model-based loop's command opposed the error at every period since
  double opposing_since_s_ = 0.0;   // then, when the reading was
  double opposing_error_c_ = 0.0;   // this far from the setpoint

  bool ambient_expected_ = false;  // an ambient sensor reports (valid or not)
  bool have_ambient_ = false;
  double ambient_c_ = 0.0;
  double ambient_time_s_ = 0.0;   // the last valid ambient reading, or the first report before one

  double opa548_off_until_s_ = 0.0;
  bool have_adc_time_ = false;
  double last_sample_s_ = 0.0;  // the last ADC sample (or the first tick, before any)
};

}  // namespace gyrotc::app
