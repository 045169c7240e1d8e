#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/control/pid.hpp"
#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/control/tec_program.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/runtime/controller_flags.hpp"
#include "gyrotc/app/runtime/fault_supervisor.hpp"
#include "gyrotc/app/runtime/rate_output.hpp"
#include "gyrotc/app/runtime/stuck_probe.hpp"
#include "gyrotc/app/runtime/tec_loop.hpp"
#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/temperature_sensor.hpp"

// The controller both runners share (docs/ARCHITECTURE.md, "One controller, two
// runners"): per-sample compensation, the 2 s PID on the TEC, and the
// fail-safe decisions of issue 6. It knows no threads, clocks or devices: the
// runner hands it samples, readings and ticks with their times and applies
// what it returns. Every on_* call is noexcept, allocation-free and lock-free.
// It is three parts and the rule between them: the rate path (RateOutput),
// the fault supervisor (FaultSupervisor: what the board's readings and
// transfers say) and the TEC loop (TecLoop: the period's current); on_pid_tick
// decides from the supervisor's flags what the loop does in the period.
namespace gyrotc::app {

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
  // The model-based loop (control/observer_loop.hpp) in the PID's place,
  // at pid.period_s = its design's period; the PID's limits still bound the
  // current. A reload that changes it brings the new loop with it
  // (ControllerReload).
  std::shared_ptr<const control::ObserverLoopDesign> observer;
  // Rate output (AD5060 #1): mid-scale = 0 deg/s.
  double rate_dac_vref_v = 5.0;
  double rate_out_v_per_dps = 0.01;  // +/-250 deg/s over 0..5 V
};

// Throws std::invalid_argument naming the field.
void validate(const ControllerConfig& config);

// Whether two controllers run the same model-based loop (the same model and
// specification design the same loop), or neither runs one. Allocates
// nothing (the real-time thread asks it at a reload).
bool same_model_based_loop(const ControllerConfig& a, const ControllerConfig& b) noexcept;

// A configuration reload (Controller::request_reload): the controller to run
// and its model-based loop, built here, off the real-time thread. When the
// reload changes the running loop or the loop's type (same_model_based_loop),
// that loop takes over at the next period from where the running one leaves
// the housing, without a kick (TecLoop::switch_observer); otherwise the
// running loop goes on with its filter.
struct ControllerReload {
  explicit ControllerReload(ControllerConfig next);
  ControllerConfig config;
  std::optional<control::ObserverLoop> observer;  // with config.observer
};

class Controller {
 public:
  // The Compensator is not owned: it must outlive its use (see set_compensator).
  Controller(const ControllerConfig& config, const fit::Compensator& compensator);
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

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
  void on_opa548_thermal(bool in_shutdown, double now_s) noexcept { supervisor_.on_opa548_thermal(in_shutdown, now_s); }
  // Every PID period: fail-safe decisions, then the PID (or the programme).
  // Invalid casing readings alone do not stop the PID: a period with no valid
  // reading holds the last current (a CRC glitch is common on w1-gpio, and
  // 0 A would be a thermal step into the gyro bias); once no valid reading
  // came for stale_periods the TEC goes off, and after recovery_readings good
  // ones the PID restarts with the integral it had. A programme gets 0 A in
  // any period with a sensor fault.
  TecCommand on_pid_tick(double now_s) noexcept;
  // What became of the period's command on the board (run_pid_tick): a
  // command the TEC path refused (a failed SPI transfer to the DAC, a failed
  // E/S write) leaves the TEC off, flagged; the controller takes it as off
  // (last_command() reports 0 A, disabled) and tries again next period,
  // restarting the PID with its integral once the path takes a command.
  void on_tec_applied(bool ok, double now_s) noexcept;
  // Since when the stage has been enabled (the first applied command of the
  // current drive); NaN while it is not driven.
  double tec_enabled_since_s() const noexcept { return tec_enabled_since_s_; }
  // Whether the rate DAC took the last sample's output (run_sample_tick).
  void on_rate_output(bool ok) noexcept { rate_.on_rate_dac_write(ok); }
  // From the next PID period on, the programme sets the TEC current instead of
  // the PID, under the same fail-safes and limits, until it says it is
  // finished; then the TEC stays off. Not owned; nullptr returns to the PID.
  // Call between PID periods (the runner's thread, or before it starts).
  void run_program(control::TecProgram* program) noexcept { loop_.run_program(program); }
  // The programme has finished (the runner may stop). Any thread.
  bool program_finished() const noexcept { return loop_.program_finished(); }

  // Calibration reload: the next on_sample uses the new compensator. The
  // caller keeps the old one alive until compensator_in_use() is the new one.
  // Safe to call from another thread than on_sample's.
  void set_compensator(const fit::Compensator& compensator) noexcept { rate_.set_compensator(compensator); }
  // The compensator on_sample last used. Once it is the one last set, the
  // sample thread holds no older one: those may be freed (any thread).
  const fit::Compensator* compensator_in_use() const noexcept { return rate_.compensator_in_use(); }

  // Configuration reload (SIGHUP): from the next PID period on, the setpoint,
  // the PID's gains, period, band and limits, pid on/off, feed-forward, ramp,
  // rail and model-based loop of `next`, bumplessly (IncrementalPid::retune;
  // a new loop adopts the running one's handover; a new setpoint ramps from
  // the one in use when setpoint_ramp_c_per_s > 0). The fail-safe limits and
  // the rate output stay. `next` is not copied here: it must stay alive, and
  // its loop with it, to the end of the run. Any thread.
  void request_reload(ControllerReload& next) noexcept { pending_.store(&next, std::memory_order_release); }
  // The reload last applied (nullptr before any). Any thread.
  const ControllerReload* reload_applied() const noexcept { return applied_.load(std::memory_order_acquire); }

  std::uint32_t flags() const noexcept {
    const std::uint32_t f = rate_.flags() | supervisor_.flags() | loop_.flags();
    const bool uncontrolled = (f & kTecPathFaults) != 0 && !tec_driving();
    return uncontrolled ? f | kFlagUncontrolled : f;
  }
  // Whether the stage drives the command, as far as the controller knows: the
  // command is enabled and neither the TEC path nor the OPA548 has failed
  // since (an OPA548 shutdown is seen between periods too: run_thermal_poll).
  bool tec_driving() const noexcept {
    return loop_.last_command().enable && (supervisor_.flags() & (kFlagOpa548Thermal | kFlagTecWriteFailed)) == 0;
  }
  // The TEC current the status and the rows report: never one the stage is
  // not driving.
  double reported_tec_a() const noexcept { return tec_driving() ? loop_.last_command().current_a : 0.0; }
  // The setpoint in use (ramping with setpoint_ramp_c_per_s).
  double active_setpoint_c() const noexcept { return loop_.active_setpoint_c(); }
  double last_casing_c() const noexcept { return supervisor_.casing_c(); }
  LoopEstimate loop_estimate() const noexcept { return loop_.estimate(); }
  // The temperature the model is evaluated at: the last casing reading, or
  // the die's estimate (NaN before the first reading).
  double compensation_c() const noexcept {
    return supervisor_.have_casing() ? die_.die_c() : std::numeric_limits<double>::quiet_NaN();
  }
  const TecCommand& last_command() const noexcept { return loop_.last_command(); }
  const ControllerConfig& config() const noexcept { return config_; }

 private:
  void apply_reload(ControllerReload& next) noexcept;
  // The loop's command for the period, as the supervisor's flags allow.
  const TecCommand& decide(double now_s) noexcept;

  ControllerConfig config_;
  std::atomic<ControllerReload*> pending_{nullptr};
  std::atomic<const ControllerReload*> applied_{nullptr};
  double tec_enabled_since_s_ = std::numeric_limits<double>::quiet_NaN();
  RateOutput rate_;
  FaultSupervisor supervisor_;  // reads config_.limits
  TecLoop loop_;                // reads config_
  StuckProbe probe_;            // reads config_.limits
  // The die's temperature from the casing readings through the compensator's
  // die lag (the readings themselves when it is 0).
  calibrate::DieTemperature die_;
};

// One PID tick as both runners do it: the OPA548 thermal state in (a state
// that cannot be read counts as a shutdown: the safe side; an unknown one,
// without a sense line or while disabled, as none), the controller's
// command out to the TEC stage. A current the DAC did not take leaves the TEC
// off rather than enabled at an unknown current.
TecCommand run_pid_tick(Controller& controller, hal::TecDriver& tec, double now_s) noexcept;

// Between PID periods, as both runners do it before each row: while the TEC
// is driven, an OPA548 thermal shutdown on E/S (or an E/S that cannot be
// read) is taken at once: flagged, the stage disabled, reported at 0 A; the
// next period turns the loop off for the cool-down. Not within
// kEsSenseSettleS of the enable: the sense line still shows the pin as it
// was while disabled (low), which would be taken for a shutdown at every
// enable, and the loop would never drive.
void run_thermal_poll(Controller& controller, hal::TecDriver& tec, double now_s) noexcept;
// The E/S sense line's settling after an enable: the board's two
// optocouplers and pull-ups (docs/BOARD-rpi4.md), and the virtual board's
// emulated line (a gpio-sim write under TCG: up to 40 ms), with margin.
inline constexpr double kEsSenseSettleS = 0.1;

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
