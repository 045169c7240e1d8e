#include "gyrotc/app/runtime/controller.hpp"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace gyrotc::app {
namespace {

void require(bool ok, const char* field, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("controller ") + field + " " + what);
}

}  // namespace

void validate(const ControllerConfig& c) {
  control::validate(c.pid);
  const auto& l = c.limits;
  require(std::isfinite(c.setpoint_c), "setpoint_c", "must be a number");
  require(c.setpoint_c > l.min_valid_c && c.setpoint_c < l.over_temp_c, "setpoint_c",
          "must lie between min_valid_c and over_temp_c");
  require(std::isfinite(c.feed_forward_a_per_c), "feed_forward_a_per_c", "must be a number");
  require(std::isfinite(c.feed_forward_lag_s) && c.feed_forward_lag_s >= 0.0, "feed_forward_lag_s",
          "must be zero or positive");
  require(std::isfinite(c.setpoint_ramp_c_per_s) && c.setpoint_ramp_c_per_s >= 0.0,
          "setpoint_ramp_c_per_s", "must be zero or positive");
  if (c.rail.known) {
    require(std::isfinite(c.rail.pos_a) && std::isfinite(c.rail.neg_a) && c.rail.neg_a < c.rail.pos_a, "rail",
            "neg_a must be below pos_a");
    require(std::isfinite(c.rail.a_per_c) && c.rail.a_per_c >= 0.0, "rail.a_per_c", "must be zero or positive");
  }
  if (c.observer) {
    require(std::fabs(c.observer->spec.period_s - c.pid.period_s) <= 1e-9 * c.pid.period_s, "observer",
            "its design's period must be the control period");
  }
  require(std::isfinite(c.rate_dac_vref_v) && c.rate_dac_vref_v > 0.0, "rate_dac_vref_v",
          "must be positive");
  require(std::isfinite(c.rate_out_v_per_dps) && c.rate_out_v_per_dps > 0.0, "rate_out_v_per_dps",
          "must be positive");
  require(std::isfinite(l.stale_periods) && l.stale_periods > 0.0, "stale_periods",
          "must be positive");
  require(std::isfinite(l.stuck_s) && l.stuck_s > 0.0, "stuck_s", "must be positive");
  require(std::isfinite(l.stuck_min_drive_a) && l.stuck_min_drive_a > 0.0, "stuck_min_drive_a",
          "must be positive");
  require(std::isfinite(l.stuck_span_a) && l.stuck_span_a > 0.0, "stuck_span_a",
          "must be positive");
  require(std::isfinite(l.stuck_sigma) && l.stuck_sigma > 0.0, "stuck_sigma", "must be positive");
  require(std::isfinite(l.stuck_sigma_s) && l.stuck_sigma_s >= 0.0, "stuck_sigma_s", "must be zero or positive");
  require(std::isfinite(l.stuck_probe_s) && l.stuck_probe_s >= 0.0, "stuck_probe_s", "must be zero (off) or positive");
  require(std::isfinite(l.stuck_probe_hold_s) && l.stuck_probe_hold_s > 0.0, "stuck_probe_hold_s",
          "must be positive");
  require(std::isfinite(l.runaway_s) && l.runaway_s > 0.0, "runaway_s", "must be positive");
  require(std::isfinite(l.runaway_c) && l.runaway_c > 0.0, "runaway_c", "must be positive");
  require(std::isfinite(l.opa548_cooldown_s) && l.opa548_cooldown_s >= 0.0, "opa548_cooldown_s",
          "must be zero or positive");
  require(std::isfinite(l.adc_stall_s) && l.adc_stall_s > 0.0, "adc_stall_s", "must be positive");
  require(std::isfinite(l.ambient_stale_s) && l.ambient_stale_s > 0.0, "ambient_stale_s", "must be positive");
  require(l.recovery_readings >= 1, "recovery_readings", "must be at least 1");
  require(std::isfinite(l.min_valid_c) && std::isfinite(l.max_valid_c) &&
              l.min_valid_c < l.max_valid_c,
          "min_valid_c", "must be below max_valid_c");
  require(std::isfinite(l.over_temp_c), "over_temp_c", "must be a number");
}

Controller::Controller(const ControllerConfig& config, const fit::Compensator& compensator)
    : config_((validate(config), config)),
      rate_(config.rate_dac_vref_v, config.rate_out_v_per_dps, compensator),
      supervisor_(config_.limits),
      loop_(config_),
      probe_(config_.limits) {
  // The model-based loop checks its readings against its model (a reload
  // keeps the loop: changing it takes a restart).
  supervisor_.set_model_check(config_.observer != nullptr);
}

SampleResult Controller::on_sample(const hal::AdcSample& sample, double now_s) noexcept {
  supervisor_.on_sample(now_s);
  SampleResult result = rate_.on_sample(sample, compensation_c(), supervisor_.have_casing());
  if (loop_.program_running() && !sample.clipped && std::isfinite(sample.gyro_mv)) {
    loop_.on_gyro_sample(sample.gyro_mv);  // the programme's mean gyro output
  }
  result.flags = flags();
  return result;
}

void Controller::on_adc_timeout(double /*now_s*/) noexcept { rate_.on_adc_timeout(); }

void Controller::on_temperature(const hal::TemperatureReading& reading, double now_s) noexcept {
  if (!supervisor_.on_temperature(reading, now_s)) return;
  // The model is evaluated at the die's temperature: the reading itself, or
  // the reading through the calibration's die lag.
  die_.update(supervisor_.casing_time_s(), reading.temp_c, rate_.compensator().die_lag_s());
  rate_.on_temperature(die_.die_c());
}

void Controller::on_ambient_temperature(const hal::TemperatureReading& reading, double now_s) noexcept {
  if (const std::optional<double> since_s = supervisor_.on_ambient_temperature(reading, now_s)) {
    loop_.on_ambient(reading.temp_c, *since_s);
  }
}

bool same_model_based_loop(const ControllerConfig& a, const ControllerConfig& b) noexcept {
  if (a.observer == nullptr || b.observer == nullptr) return a.observer == b.observer;
  return a.observer->model == b.observer->model && a.observer->spec == b.observer->spec;
}

ControllerReload::ControllerReload(ControllerConfig next) : config(std::move(next)) {
  if (config.observer) observer.emplace(config.observer);
}

void Controller::apply_reload(ControllerReload& next) noexcept {
  const ControllerConfig& c = next.config;
  config_.setpoint_c = c.setpoint_c;
  config_.pid = c.pid;
  config_.pid_enabled = c.pid_enabled;
  config_.feed_forward_a_per_c = c.feed_forward_a_per_c;
  config_.feed_forward_lag_s = c.feed_forward_lag_s;
  config_.setpoint_ramp_c_per_s = c.setpoint_ramp_c_per_s;
  config_.rail = c.rail;
  loop_.retune(c.pid);
  // Against the loop running, not the last reload asked for: one that came
  // in the same period may have been skipped.
  if (!same_model_based_loop(config_, c)) {
    // The old design stays alive in the reload (or the start) that brought it.
    config_.observer = c.observer;
    supervisor_.set_model_check(config_.observer != nullptr);
    supervisor_.clear_loop_runaway();
    loop_.switch_observer(next.observer ? &*next.observer : nullptr);
  }
  applied_.store(&next, std::memory_order_release);
}

TecCommand Controller::on_pid_tick(double now_s) noexcept {
  if (ControllerReload* next = pending_.exchange(nullptr, std::memory_order_acq_rel)) apply_reload(*next);
  supervisor_.on_tick(now_s, config_.pid.period_s);
  const TecCommand& command = decide(now_s);
  // The stuck check's evidence: what the TEC drove this period.
  supervisor_.record_command(command.enable ? command.current_a : 0.0);
  supervisor_.on_reading_check(loop_.reading_surprise(), now_s);
  supervisor_.on_loop_command(loop_.model_drove(), command.enable ? command.current_a : 0.0, loop_.active_setpoint_c(),
                              now_s);
  // From the next period on the PID holds in its place, until a reload brings
  // another loop; its stuck check is the PID's (the command's swing).
  if ((supervisor_.flags() & kFlagLoopRunaway) != 0) {
    loop_.fall_back_to_pid();
    supervisor_.set_model_check(false);
  }
  // The probe needs a loop that can move the casing: the model-based one,
  // driving, off its current limit (there a live reading need not follow).
  if (loop_.model_drove() && (command.flags & kFlagTecSaturated) == 0) {
    loop_.set_target_offset_c(probe_.on_period(now_s, supervisor_.casing_c(), supervisor_.reading_unchanged_s(now_s),
                                               loop_.active_setpoint_c()));
    if (probe_.take_failed()) supervisor_.on_probe_failed();
  } else {
    probe_.cancel();
    loop_.set_target_offset_c(0.0);
  }
  loop_.set_command_flags(flags());
  return loop_.last_command();
}

const TecCommand& Controller::decide(double now_s) noexcept {
  const std::uint32_t faults = supervisor_.flags();
  const bool new_reading = supervisor_.take_new_reading();
  // The identification programme gets no glitch hold: a period with a sensor
  // fault is a period at 0 A, and the record shows it.
  if (loop_.program_running() && (faults & FaultSupervisor::kTempFaults) != 0) return loop_.off(now_s, false);
  // A reading that went stale (invalid ones only, since the last valid one)
  // ends a hold: off, to restart with the PID's integral once readings are good.
  if ((faults & kFlagTempStale) != 0) return loop_.off(now_s, true);
  const std::uint32_t stop = kFlagTempStuck | kFlagOverTempLatched | kFlagOpa548Thermal;
  if ((faults & stop) != 0 || !config_.pid_enabled || loop_.program_finished()) return loop_.off(now_s, false);
  const double casing_c = supervisor_.casing_c();
  const double ambient_c = supervisor_.ambient_c();
  if (loop_.program_running()) return loop_.program_tick(now_s, casing_c, ambient_c, rate_.scale_mv_per_dps());
  if ((faults & kFlagTempInvalid) != 0) {
    if (!loop_.pid_running()) return loop_.off(now_s, loop_.resuming());  // not recovered yet (M good readings)
    // Glitch tolerance: no valid reading this period, only invalid ones.
    // Hold the last current (no step on old news) until the reading is stale.
    if (!new_reading) return loop_.hold(now_s);
  }
  return loop_.pid_tick(now_s, casing_c, ambient_c, now_s - supervisor_.casing_time_s());
}

void Controller::on_tec_applied(bool ok, double now_s) noexcept {
  supervisor_.on_tec_write(ok);
  if (!(ok && loop_.last_command().enable)) {
    tec_enabled_since_s_ = std::numeric_limits<double>::quiet_NaN();
  } else if (std::isnan(tec_enabled_since_s_)) {
    tec_enabled_since_s_ = now_s;
  }
  if (!ok && loop_.last_command().enable) {
    loop_.off(now_s, true);
    supervisor_.record_command(0.0);
  }
  loop_.set_command_flags(flags());
}

TecCommand run_pid_tick(Controller& controller, hal::TecDriver& tec, double now_s) noexcept {
  const auto thermal = tec.thermal_status();
  controller.on_opa548_thermal(!thermal.ok() || thermal.value() == hal::ThermalStatus::shutdown, now_s);
  const TecCommand command = controller.on_pid_tick(now_s);
  bool applied = false;
  if (command.enable) {
    applied = tec.set_current_a(command.current_a).ok() && tec.enable(true).ok();
    if (!applied) (void)tec.safe_off();  // not enabled at a current the DAC may not hold
  } else {
    applied = tec.safe_off().ok();
  }
  controller.on_tec_applied(applied, now_s);
  return controller.last_command();
}

void run_thermal_poll(Controller& controller, hal::TecDriver& tec, double now_s) noexcept {
  if (!controller.tec_driving() || !(now_s - controller.tec_enabled_since_s() >= kEsSenseSettleS)) return;
  const auto thermal = tec.thermal_status();
  if (thermal.ok() && thermal.value() != hal::ThermalStatus::shutdown) return;
  controller.on_opa548_thermal(true, now_s);
  (void)tec.safe_off();
}

double RowAccumulator::mean_gyro_mv() const noexcept {
  return gyro_count > 0 ? gyro_sum_mv / static_cast<double>(gyro_count) : std::numeric_limits<double>::quiet_NaN();
}

double RowAccumulator::mean_rate_dps() const noexcept {
  return rate_count > 0 ? rate_sum_dps / static_cast<double>(rate_count) : std::numeric_limits<double>::quiet_NaN();
}

SampleResult run_sample_tick(Controller& controller, hal::RateDac& rate_dac, const hal::AdcSample& sample,
                             double now_s, RowAccumulator& row) noexcept {
  const SampleResult r = controller.on_sample(sample, now_s);
  controller.on_rate_output(rate_dac.write_v(r.rate_out_v).ok());
  row.gyro_sum_mv += sample.gyro_mv;
  ++row.gyro_count;
  if (r.valid) {
    row.rate_sum_dps += r.rate_dps;
    ++row.rate_count;
  }
  row.flags |= controller.flags();
  return r;
}

void run_adc_timeout_tick(Controller& controller, hal::RateDac& rate_dac, double now_s,
                          RowAccumulator& row) noexcept {
  controller.on_adc_timeout(now_s);
  controller.on_rate_output(rate_dac.write_v(0.5 * controller.config().rate_dac_vref_v).ok());
  row.flags |= controller.flags();
}

}  // namespace gyrotc::app
