#include "gyrotc/app/runtime/controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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
  require(std::isfinite(l.opa548_cooldown_s) && l.opa548_cooldown_s >= 0.0, "opa548_cooldown_s",
          "must be zero or positive");
  require(std::isfinite(l.adc_stall_s) && l.adc_stall_s > 0.0, "adc_stall_s", "must be positive");
  require(l.recovery_readings >= 1, "recovery_readings", "must be at least 1");
  require(std::isfinite(l.min_valid_c) && std::isfinite(l.max_valid_c) &&
              l.min_valid_c < l.max_valid_c,
          "min_valid_c", "must be below max_valid_c");
  require(std::isfinite(l.over_temp_c), "over_temp_c", "must be a number");
}

Controller::Controller(const ControllerConfig& config, const fit::Compensator& compensator)
    : config_(config),
      compensator_(&compensator),
      in_use_(&compensator),
      pid_((validate(config), config.pid)),
      active_setpoint_c_(config.setpoint_c) {}

void Controller::set_flag(std::uint32_t flag, bool on) noexcept {
  flags_ = on ? (flags_ | flag) : (flags_ & ~flag);
}

const char* flag_name(std::uint32_t flag) noexcept {
  switch (flag) {
    case kFlagTempStale: return "temp_stale";
    case kFlagTempInvalid: return "temp_invalid";
    case kFlagTempStuck: return "temp_stuck";
    case kFlagOverTempLatched: return "over_temp_latched";
    case kFlagOpa548Thermal: return "opa548_thermal";
    case kFlagAdcInvalid: return "adc_invalid";
    case kFlagModelClamped: return "model_clamped";
    case kFlagTecSaturated: return "tec_saturated";
    case kFlagTecOff: return "tec_off";
    case kFlagAdcStalled: return "adc_stalled";
    case kFlagTecWriteFailed: return "tec_write_failed";
    case kFlagRateDacFailed: return "rate_dac_failed";
    default: return "";
  }
}

std::string flag_names(std::uint32_t flags) {
  std::string names;
  for (unsigned bit = 0; bit < 32; ++bit) {
    const std::uint32_t flag = 1u << bit;
    if ((flags & flag) == 0) continue;
    const std::string name = flag_name(flag);
    names += (names.empty() ? "" : "+") + (name.empty() ? "bit " + std::to_string(bit) : name);
  }
  return names.empty() ? "none" : names;
}

SampleResult Controller::on_sample(const hal::AdcSample& sample, double now_s) noexcept {
  have_adc_time_ = true;
  last_sample_s_ = now_s;
  set_flag(kFlagAdcStalled, false);
  const fit::Compensator* compensator = compensator_.load(std::memory_order_acquire);
  // The modelled bias only changes with the casing reading (about once a
  // second) or the model: evaluate it then, and subtract it from every sample.
  if (compensator != cached_compensator_ || !bias_cached_) {
    const double temp_c = have_casing_ ? die_.die_c() : std::numeric_limits<double>::quiet_NaN();
    cached_temp_c_ = temp_c;
    const fit::Compensated c = compensator->compensate(0.0, temp_c);
    cached_compensator_ = compensator;
    cached_bias_mv_ = c.bias_mv;
    // Before the first casing reading there is no temperature to be outside
    // the calibrated range: the rate is invalid (NaN bias), not clamped.
    cached_clamped_ = have_casing_ && c.temp_clamped;
    inverse_scale_ = 1.0 / compensator->scale_mv_per_dps();
    bias_cached_ = true;
    // Release: every use of an older compensator happens before a reader sees this one.
    in_use_.store(compensator, std::memory_order_release);
  }
  SampleResult result;
  set_flag(kFlagModelClamped, cached_clamped_);
  const double rate_dps = (sample.gyro_mv - cached_bias_mv_) * inverse_scale_;
  result.valid = !sample.clipped && std::isfinite(rate_dps);
  set_flag(kFlagAdcInvalid, sample.clipped);
  if (program_ != nullptr && !sample.clipped && std::isfinite(sample.gyro_mv)) {
    program_gyro_sum_mv_ += sample.gyro_mv;
    ++program_gyro_count_;
  }
  result.bias_mv = cached_bias_mv_;
  const double mid_v = 0.5 * config_.rate_dac_vref_v;
  if (result.valid) {
    result.rate_dps = rate_dps;
    result.rate_out_v = std::clamp(mid_v + rate_dps * config_.rate_out_v_per_dps, 0.0,
                                   config_.rate_dac_vref_v);
  } else {
    result.rate_dps = std::numeric_limits<double>::quiet_NaN();
    result.rate_out_v = mid_v;
  }
  result.flags = flags_;
  return result;
}

void Controller::on_adc_timeout(double /*now_s*/) noexcept { set_flag(kFlagAdcInvalid, true); }

void Controller::on_temperature(const hal::TemperatureReading& reading, double now_s) noexcept {
  const auto& l = config_.limits;
  const bool plausible = reading.valid && std::isfinite(reading.temp_c) &&
                         reading.temp_c >= l.min_valid_c && reading.temp_c <= l.max_valid_c;
  if (!plausible) {
    set_flag(kFlagTempInvalid, true);
    good_streak_ = 0;
    return;
  }
  reading_since_tick_ = true;
  if (reading.temp_c >= l.over_temp_c) set_flag(kFlagOverTempLatched, true);
  if (!have_casing_ || reading.temp_c != casing_c_) {
    changed_at_s_ = now_s;
    drive_min_abs_a_ = std::numeric_limits<double>::infinity();
    drive_lo_a_ = std::numeric_limits<double>::infinity();
    drive_hi_a_ = -std::numeric_limits<double>::infinity();
  }
  have_casing_ = true;
  casing_c_ = reading.temp_c;
  // A reading is as old as its measurement (the conversion's start), not
  // its hand-over: a conversion takes 750 ms, more behind the ambient's.
  casing_time_s_ = std::isfinite(reading.time_s) ? std::min(reading.time_s, now_s) : now_s;
  // The model is evaluated at the die's temperature: the reading itself, or
  // the reading through the calibration's die lag.
  die_.update(casing_time_s_, reading.temp_c, compensator_.load(std::memory_order_acquire)->die_lag_s());
  if (die_.die_c() != cached_temp_c_) bias_cached_ = false;
  if ((flags_ & kTempFaults) != 0) {
    const bool still_stuck = (flags_ & kFlagTempStuck) != 0 && reading.temp_c == stuck_value_c_;
    good_streak_ = still_stuck ? 0 : good_streak_ + 1;
    if (good_streak_ >= l.recovery_readings) {
      set_flag(kTempFaults, false);
      good_streak_ = 0;
    }
  }
}

void Controller::on_ambient_temperature(const hal::TemperatureReading& reading, double now_s) noexcept {
  const auto& l = config_.limits;
  if (reading.valid && std::isfinite(reading.temp_c) && reading.temp_c >= l.min_valid_c &&
      reading.temp_c <= l.max_valid_c) {
    ff_ambient_.update(reading.temp_c, have_ambient_ ? now_s - ambient_time_s_ : 0.0, config_.feed_forward_lag_s);
    have_ambient_ = true;
    ambient_c_ = reading.temp_c;
    ambient_time_s_ = now_s;
  }
}

void Controller::on_opa548_thermal(bool in_shutdown, double now_s) noexcept {
  if (in_shutdown) {
    set_flag(kFlagOpa548Thermal, true);
    opa548_off_until_s_ = now_s + config_.limits.opa548_cooldown_s;
  } else if (now_s >= opa548_off_until_s_) {
    set_flag(kFlagOpa548Thermal, false);
  }
}

void Controller::record_command(double current_a) noexcept {
  drive_min_abs_a_ = std::min(drive_min_abs_a_, std::fabs(current_a));
  drive_lo_a_ = std::min(drive_lo_a_, current_a);
  drive_hi_a_ = std::max(drive_hi_a_, current_a);
}

TecCommand Controller::off(double now_s, bool resume) noexcept {
  set_flag(kFlagTecOff, true);
  set_flag(kFlagTecSaturated, false);
  if (pid_running_) {
    resume_ = resume;
    resume_integral_a_ = resume ? pid_.integral() : 0.0;
  }
  pid_running_ = false;
  pid_.reset(0.0);
  record_command(0.0);
  command_ = TecCommand{0.0, false, flags_};
  last_tick_s_ = now_s;
  return command_;
}

void Controller::apply_reload(const ControllerConfig& next) noexcept {
  config_.setpoint_c = next.setpoint_c;
  config_.pid = next.pid;
  config_.pid_enabled = next.pid_enabled;
  config_.feed_forward_a_per_c = next.feed_forward_a_per_c;
  config_.feed_forward_lag_s = next.feed_forward_lag_s;
  config_.setpoint_ramp_c_per_s = next.setpoint_ramp_c_per_s;
  config_.rail = next.rail;
  pid_.retune(next.pid);
  resume_integral_a_ = std::clamp(resume_integral_a_, next.pid.out_min, next.pid.out_max);
  applied_.store(&next, std::memory_order_release);
}

TecCommand Controller::on_pid_tick(double now_s) noexcept {
  if (const ControllerConfig* next = pending_.exchange(nullptr, std::memory_order_acq_rel)) apply_reload(*next);
  const auto& l = config_.limits;
  const double period_s = config_.pid.period_s;

  const bool stale = !have_casing_ || now_s - casing_time_s_ > l.stale_periods * period_s;
  if (stale && (flags_ & kFlagTempStale) == 0) {
    set_flag(kFlagTempStale, true);
    good_streak_ = 0;
  }
  const bool driving = drive_min_abs_a_ >= l.stuck_min_drive_a || drive_hi_a_ - drive_lo_a_ >= l.stuck_span_a;
  if (have_casing_ && (flags_ & kFlagTempStuck) == 0 && now_s - changed_at_s_ >= l.stuck_s &&
      drive_hi_a_ >= drive_lo_a_ && driving) {
    set_flag(kFlagTempStuck, true);
    stuck_value_c_ = casing_c_;
    good_streak_ = 0;
  }

  if (!have_adc_time_) {  // the stall is counted from the first tick when no sample came yet
    have_adc_time_ = true;
    last_sample_s_ = now_s;
  }
  if (now_s - last_sample_s_ > l.adc_stall_s) set_flag(kFlagAdcStalled, true);

  const bool new_reading = std::exchange(reading_since_tick_, false);
  // The identification programme gets no glitch hold: a period with a sensor
  // fault is a period at 0 A, and the record shows it.
  if (program_ != nullptr && (flags_ & kTempFaults) != 0) return off(now_s, false);
  // A reading that went stale (invalid ones only, since the last valid one)
  // ends a hold: off, to restart where the PID was once readings are good.
  if ((flags_ & kFlagTempStale) != 0) return off(now_s, true);
  // A dead ADC: off, to restart where the PID was once samples come again.
  if ((flags_ & kFlagAdcStalled) != 0) return off(now_s, true);
  const std::uint32_t stop = kFlagTempStuck | kFlagOverTempLatched | kFlagOpa548Thermal;
  if ((flags_ & stop) != 0 || !config_.pid_enabled || program_finished()) return off(now_s, false);
  if (program_ != nullptr) return program_tick(now_s);
  if ((flags_ & kFlagTempInvalid) != 0) {
    if (!pid_running_) return off(now_s, resume_);  // not recovered yet (M good readings)
    // Glitch tolerance: no valid reading this period, only invalid ones.
    // Hold the last current (no step on old news) until the reading is stale.
    if (!new_reading) {
      record_command(command_.current_a);
      command_.flags = flags_;
      last_tick_s_ = now_s;
      return command_;
    }
  }

  const double dt_s = pid_running_ ? now_s - last_tick_s_ : 0.0;
  if (!pid_running_) {
    // After a sensor fault (stale) or a dead ADC the PID restarts with the
    // integral it had (what it learnt of the load), its proportional part on
    // the error now: a casing that cooled while the TEC was off is heated
    // back (IncrementalPid::integral). After any other stop it starts from
    // 0 A. No derivative kick either way.
    pid_.reset(resume_ ? resume_integral_a_ : 0.0);
    resume_ = false;
    resume_integral_a_ = 0.0;
    active_setpoint_c_ = config_.setpoint_ramp_c_per_s > 0.0 ? casing_c_ : config_.setpoint_c;
    pid_running_ = true;
  }
  if (config_.setpoint_ramp_c_per_s > 0.0) {
    const double step = config_.setpoint_ramp_c_per_s * dt_s;
    active_setpoint_c_ += std::clamp(config_.setpoint_c - active_setpoint_c_, -step, step);
  } else {
    active_setpoint_c_ = config_.setpoint_c;
  }
  const double ff = control::feed_forward_a(config_.feed_forward_a_per_c, config_.setpoint_c, ff_ambient_.value_c());
  // Anti-windup on the current applied (issue 22): control/tec_law.hpp.
  const double current_a = control::pid_current_a(pid_, casing_c_, active_setpoint_c_, ff, applied_range());
  return drive(current_a, pid_.saturated(), now_s);
}

control::CurrentRange Controller::applied_range() const noexcept {
  return control::applied_range(config_.pid.out_min, config_.pid.out_max, config_.rail, casing_c_, ambient_reading());
}

double Controller::ambient_reading() const noexcept {
  return have_ambient_ ? ambient_c_ : std::numeric_limits<double>::quiet_NaN();
}

TecCommand Controller::drive(double current_a, bool saturated, double now_s) noexcept {
  set_flag(kFlagTecOff, false);
  set_flag(kFlagTecSaturated, saturated);
  record_command(current_a);
  command_ = TecCommand{current_a, true, flags_};
  last_tick_s_ = now_s;
  return command_;
}

void Controller::run_program(control::TecProgram* program) noexcept {
  program_ = program;
  program_started_ = false;
  program_gyro_sum_mv_ = 0.0;
  program_gyro_count_ = 0;
  program_finished_.store(false, std::memory_order_release);
  pid_running_ = false;
}

TecCommand Controller::program_tick(double now_s) noexcept {
  if (!program_started_) {
    program_started_ = true;
    program_start_s_ = now_s;
  }
  control::TecProgramInput in;
  in.time_s = now_s - program_start_s_;
  in.casing_c = casing_c_;
  in.ambient_c = ambient_reading();
  in.setpoint_c = config_.setpoint_c;
  const control::CurrentRange range = applied_range();
  in.min_a = range.min_a;
  in.max_a = range.max_a;
  in.gyro_mv = program_gyro_count_ > 0 ? program_gyro_sum_mv_ / static_cast<double>(program_gyro_count_)
                                        : std::numeric_limits<double>::quiet_NaN();
  in.gyro_scale_mv_per_dps = 1.0 / inverse_scale_;
  program_gyro_sum_mv_ = 0.0;
  program_gyro_count_ = 0;
  active_setpoint_c_ = config_.setpoint_c;
  const control::TecProgramOutput out = program_->next(in);
  if (out.finished || !std::isfinite(out.current_a)) {
    program_finished_.store(true, std::memory_order_release);
    return off(now_s, false);
  }
  const double current_a = std::clamp(out.current_a, in.min_a, in.max_a);
  return drive(current_a, current_a != out.current_a, now_s);
}

void Controller::on_tec_applied(bool ok, double now_s) noexcept {
  set_flag(kFlagTecWriteFailed, !ok);
  if (!ok && command_.enable) (void)off(now_s, true);
  command_.flags = flags_;
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
