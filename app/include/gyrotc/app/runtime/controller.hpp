#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <string>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/control/pid.hpp"
#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/control/tec_program.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/temperature_sensor.hpp"

// The controller both runners share (docs/ARCHITECTURE.md, "One controller, two
// runners"): per-sample compensation, the 2 s PID on the TEC, and the
// fail-safe decisions of issue 6. It knows no threads, clocks or devices: the
// runner hands it samples, readings and ticks with their times and applies
// what it returns. Every on_* call is noexcept, allocation-free and lock-free.
namespace gyrotc::app {

// Flags reported with every sample and TEC command (bitmask).
enum ControllerFlag : std::uint32_t {
  kFlagTempStale = 1u << 0,       // no valid casing reading measured in the last stale_periods PID periods
  kFlagTempInvalid = 1u << 1,     // an invalid casing reading (CRC, 85 C reset, range) since the last M good ones
  kFlagTempStuck = 1u << 2,       // the casing reading has not changed while the TEC drives
  kFlagOverTempLatched = 1u << 3, // casing over-temperature: TEC off until restart
  kFlagOpa548Thermal = 1u << 4,   // the OPA548 reports thermal shutdown
  kFlagAdcInvalid = 1u << 5,      // ADC timeout or clipped sample: the rate output is invalid
  kFlagModelClamped = 1u << 6,    // compensation temperature outside the calibrated range
  kFlagTecSaturated = 1u << 7,    // the PID output is at its limit
  kFlagTecOff = 1u << 8,          // the TEC is commanded off (0 A, OPA548 disabled)
  kFlagAdcStalled = 1u << 9,      // no ADC sample for adc_stall_s: TEC off until samples return
  kFlagTecWriteFailed = 1u << 10, // the TEC DAC or the OPA548's E/S line refused the command: TEC off, retried
  kFlagRateDacFailed = 1u << 11,  // the rate DAC refused the compensated output: the analog rate is stale
};

// The name of each flag bit (for the journal); "" for a bit that is none.
const char* flag_name(std::uint32_t flag) noexcept;
// Every flag set in `flags` by name, joined by '+' ("tec_off+model_clamped"),
// "none" for none and "bit N" for a bit that is no flag: what a person reads
// in place of the CSV's number.
std::string flag_names(std::uint32_t flags);

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
  // Consecutive good readings that clear a stale/invalid/stuck fault.
  int recovery_readings = 3;
  // Casing over-temperature: latched off (the DS18B20 itself goes to 125 C).
  double over_temp_c = 80.0;
  // After an OPA548 thermal flag the TEC stays off this long before it is
  // retried: with E/S released the flag can only be seen while enabled, so a
  // disabled part reads "no fault" whether or not its junction has cooled.
  double opa548_cooldown_s = 60.0;
  // No ADC sample for this long (DRDY never falls, every read fails): the
  // converter or its clock is dead, and with it the unit's output; the board
  // fault may be one the TEC path shares (supply, SPI). The TEC goes off
  // until samples come again, then the PID restarts where it stopped.
  double adc_stall_s = 10.0;
  // Plausible casing range; outside it a reading is invalid (DS18B20: -55..125 C).
  double min_valid_c = -55.0;
  double max_valid_c = 125.0;
};

// The stage's rail limit (issue 22): control/tec_law.hpp.
using control::RailLimit;

struct ControllerConfig {
  double setpoint_c = 55.0;  // seed Section 6: optimal working temperature ~55 C
  control::PidParams pid;    // seed Eq. 17/18 defaults; out_min/out_max = TEC current limits
  bool pid_enabled = true;   // false: the TEC stays off (compensation only)
  FailSafeLimits limits;
  // Tuned options (all off = the seed's controller).
  // Feed-forward from the ambient sensor: I_ff = ff_a_per_c * (setpoint - ambient),
  // the ambient reading through a first-order lag of feed_forward_lag_s (the
  // housing's, control/tec_law.hpp AmbientLag; 0 = the reading itself).
  double feed_forward_a_per_c = 0.0;
  double feed_forward_lag_s = 0.0;
  // Setpoint ramp from the first casing reading (C/s); 0 = a step.
  double setpoint_ramp_c_per_s = 0.0;
  // The stage's rail limit, when known; the PID's anti-windup and the current
  // applied respect it as they do out_min/out_max.
  RailLimit rail;
  // Rate output (AD5060 #1): mid-scale = 0 deg/s.
  double rate_dac_vref_v = 5.0;
  double rate_out_v_per_dps = 0.01;  // +/-250 deg/s over 0..5 V
};

// Throws std::invalid_argument naming the field.
void validate(const ControllerConfig& config);

struct SampleResult {
  double rate_dps = 0.0;    // compensated rate (NaN when not valid)
  double bias_mv = 0.0;     // modelled zero-rate output subtracted
  double rate_out_v = 0.0;  // for the rate DAC (mid-scale when not valid)
  bool valid = false;
  std::uint32_t flags = 0;
};

struct TecCommand {
  double current_a = 0.0;
  bool enable = false;
  std::uint32_t flags = 0;
};

class Controller {
 public:
  // The Compensator is not owned: it must outlive its use (see set_compensator).
  Controller(const ControllerConfig& config, const fit::Compensator& compensator);

  // Every ADC sample: compensation at the last valid casing temperature, or,
  // with a calibration of the die (fit::Compensator::die_lag_s), at the die's
  // temperature estimated from the casing readings through that lag.
  SampleResult on_sample(const hal::AdcSample& sample, double now_s) noexcept;
  // The ADC did not deliver in time: the rate output is invalid until the
  // next good sample.
  void on_adc_timeout(double now_s) noexcept;
  // A casing reading (DS18B20 in the casing) / an optional ambient reading.
  void on_temperature(const hal::TemperatureReading& reading, double now_s) noexcept;
  void on_ambient_temperature(const hal::TemperatureReading& reading, double now_s) noexcept;
  // The OPA548 E/S thermal flag as last read (reads false while disabled):
  // a true flag turns the TEC off for at least opa548_cooldown_s.
  void on_opa548_thermal(bool in_shutdown, double now_s) noexcept;
  // Every PID period: fail-safe decisions, then the PID (or the programme).
  // Invalid casing readings alone do not stop the PID: a period with no valid
  // reading holds the last current (a CRC glitch is common on w1-gpio, and
  // 0 A would be a thermal step into the gyro bias); once no valid reading
  // came for stale_periods the TEC goes off, and after recovery_readings good
  // ones the PID restarts bumplessly from where it stopped. A programme gets
  // 0 A in any period with a sensor fault.
  TecCommand on_pid_tick(double now_s) noexcept;
  // What became of the period's command on the board (run_pid_tick): a
  // command the TEC path refused (a failed SPI transfer to the DAC, a failed
  // E/S write) leaves the TEC off, flagged; the controller takes it as off
  // (last_command() reports 0 A, disabled) and tries again next period,
  // restarting the PID with its integral once the path takes a command.
  void on_tec_applied(bool ok, double now_s) noexcept;
  // Whether the rate DAC took the last sample's output (run_sample_tick).
  void on_rate_output(bool ok) noexcept { set_flag(kFlagRateDacFailed, !ok); }
  // From the next PID period on, the programme sets the TEC current instead of
  // the PID, under the same fail-safes and limits, until it says it is
  // finished; then the TEC stays off. Not owned; nullptr returns to the PID.
  // Call between PID periods (the runner's thread, or before it starts).
  void run_program(control::TecProgram* program) noexcept;
  // The programme has finished (the runner may stop). Any thread.
  bool program_finished() const noexcept { return program_finished_.load(std::memory_order_acquire); }

  // Calibration reload: the next on_sample uses the new compensator. The
  // caller keeps the old one alive until compensator_in_use() is the new one.
  // Safe to call from another thread than on_sample's.
  void set_compensator(const fit::Compensator& compensator) noexcept {
    compensator_.store(&compensator, std::memory_order_release);
  }
  // The compensator on_sample last used. Once it is the one last set, the
  // sample thread holds no older one: those may be freed (any thread).
  const fit::Compensator* compensator_in_use() const noexcept { return in_use_.load(std::memory_order_acquire); }

  // Configuration reload (SIGHUP): from the next PID period on, the setpoint,
  // the PID's gains, period, band and limits, pid on/off, feed-forward, ramp
  // and rail of `next`, bumplessly (IncrementalPid::retune; a new setpoint
  // ramps from the one in use when setpoint_ramp_c_per_s > 0). The fail-safe
  // limits and the rate output stay. `next` is not copied here: it must stay
  // alive until reload_applied() returns it. Any thread.
  void request_reload(const ControllerConfig& next) noexcept { pending_.store(&next, std::memory_order_release); }
  // The reload last applied (nullptr before any). Any thread.
  const ControllerConfig* reload_applied() const noexcept { return applied_.load(std::memory_order_acquire); }

  std::uint32_t flags() const noexcept { return flags_; }
  // The setpoint in use (ramping with setpoint_ramp_c_per_s).
  double active_setpoint_c() const noexcept { return active_setpoint_c_; }
  double last_casing_c() const noexcept { return casing_c_; }
  // The temperature the model is evaluated at: the last casing reading, or
  // the die's estimate (NaN before the first reading).
  double compensation_c() const noexcept {
    return have_casing_ ? die_.die_c() : std::numeric_limits<double>::quiet_NaN();
  }
  const TecCommand& last_command() const noexcept { return command_; }
  const ControllerConfig& config() const noexcept { return config_; }

 private:
  static constexpr std::uint32_t kTempFaults = kFlagTempStale | kFlagTempInvalid | kFlagTempStuck;

  void set_flag(std::uint32_t flag, bool on) noexcept;
  void record_command(double current_a) noexcept;
  // TEC off. With `resume`, the PID (if it was running) restarts with the
  // integral it has now (IncrementalPid::integral); without, from 0 A.
  TecCommand off(double now_s, bool resume) noexcept;
  TecCommand drive(double current_a, bool saturated, double now_s) noexcept;
  // The current the stage can apply now: out_min/out_max within the rails.
  control::CurrentRange applied_range() const noexcept;
  double ambient_reading() const noexcept;  // NaN without one
  TecCommand program_tick(double now_s) noexcept;
  void apply_reload(const ControllerConfig& next) noexcept;

  ControllerConfig config_;
  std::atomic<const fit::Compensator*> compensator_;
  std::atomic<const fit::Compensator*> in_use_;
  std::atomic<const ControllerConfig*> pending_{nullptr};
  std::atomic<const ControllerConfig*> applied_{nullptr};
  control::IncrementalPid pid_;
  std::uint32_t flags_ = kFlagTecOff;

  // Casing reading state.
  bool have_casing_ = false;
  double casing_c_ = 0.0;
  double casing_time_s_ = 0.0;   // when the last valid reading was measured
  double changed_at_s_ = 0.0;    // when the value last changed
  int good_streak_ = 0;
  double stuck_value_c_ = 0.0;   // the value that tripped the stuck fault
  // TEC drive since the reading last changed (for the stuck check).
  double drive_min_abs_a_ = 0.0;
  double drive_lo_a_ = 0.0;
  double drive_hi_a_ = 0.0;

  // The die's temperature from the casing readings through the compensator's
  // die lag (the readings themselves when it is 0).
  calibrate::DieTemperature die_;
  // Compensation cache: the bias at the current temperature and model.
  const fit::Compensator* cached_compensator_ = nullptr;
  double cached_temp_c_ = std::numeric_limits<double>::quiet_NaN();
  bool bias_cached_ = false;
  double cached_bias_mv_ = 0.0;
  bool cached_clamped_ = false;
  double inverse_scale_ = 1.0;

  bool have_ambient_ = false;
  double ambient_c_ = 0.0;
  double ambient_time_s_ = 0.0;
  control::AmbientLag ff_ambient_;  // what the feed-forward answers

  double opa548_off_until_s_ = 0.0;
  bool have_adc_time_ = false;
  double last_sample_s_ = 0.0;  // the last ADC sample (or the first tick, before any)

  bool pid_running_ = false;
  bool reading_since_tick_ = false;  // a valid casing reading came since the last tick
  bool resume_ = false;              // the next start continues the PID where a fault stopped it
  double resume_integral_a_ = 0.0;   // the PID integral to restart with
  control::TecProgram* program_ = nullptr;
  bool program_started_ = false;
  double program_start_s_ = 0.0;
  double program_gyro_sum_mv_ = 0.0;  // the samples since the programme's last period
  std::size_t program_gyro_count_ = 0;
  std::atomic<bool> program_finished_{false};
  double active_setpoint_c_;
  double last_tick_s_ = 0.0;
  TecCommand command_;
};

// One PID tick as both runners do it: the OPA548 thermal state in (a state
// that cannot be read counts as a shutdown: the safe side; an unknown one,
// without a sense line or while disabled, as none), the controller's
// command out to the TEC stage. A current the DAC did not take leaves the TEC
// off rather than enabled at an unknown current.
TecCommand run_pid_tick(Controller& controller, hal::TecDriver& tec, double now_s) noexcept;

// What the per-sample path produced since the last output row: the sums for
// the mean raw and compensated rate, and every flag raised. Both runners
// average their rows with one.
struct RowAccumulator {
  double gyro_sum_mv = 0.0;
  double rate_sum_dps = 0.0;
  std::uint64_t gyro_count = 0;
  std::uint64_t rate_count = 0;  // valid compensated samples only
  std::uint32_t flags = 0;

  double mean_gyro_mv() const noexcept;   // NaN when no sample came
  double mean_rate_dps() const noexcept;  // NaN when no valid sample came
};

// One ADC sample as both runners handle it: compensated by the controller,
// the rate out to the rate DAC, the row sums updated.
SampleResult run_sample_tick(Controller& controller, hal::RateDac& rate_dac, const hal::AdcSample& sample,
                             double now_s, RowAccumulator& row) noexcept;

// An ADC timeout as both runners handle it: the controller is told and the
// rate DAC goes to mid-scale (zero rate) until the next good sample.
void run_adc_timeout_tick(Controller& controller, hal::RateDac& rate_dac, double now_s,
                          RowAccumulator& row) noexcept;

// The DS18B20 schedule both runners keep. The casing and the ambient sensor
// share one 1-Wire bus and convert one after the other (750 ms each), and the
// casing reading is the PID's input, so the ambient converts only before every
// kAmbientEveryReadings-th casing conversion, the first one included: that
// sensor cycle takes 1.5 s instead of 1 s, and its casing reading goes out as
// soon as it is converted, with the fresh ambient reading. A chamber ramps
// ~1 C/min: 0.2 C between ambient readings.
inline constexpr std::uint64_t kAmbientEveryReadings = 10;
inline bool ambient_conversion_due(std::uint64_t casing_conversion) noexcept {
  return casing_conversion % kAmbientEveryReadings == 0;
}

}  // namespace gyrotc::app
