#include "gyrotc/app/runtime/fault_supervisor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace gyrotc::app {

void FaultSupervisor::on_sample(double now_s) noexcept {
  have_adc_time_ = true;
  last_sample_s_ = now_s;
  set_flag(flags_, kFlagAdcStalled, false);
}

bool FaultSupervisor::on_temperature(const hal::TemperatureReading& reading, double now_s) noexcept {
  const auto& l = limits_;
  const bool plausible = reading.valid && std::isfinite(reading.temp_c) &&
                         reading.temp_c >= l.min_valid_c && reading.temp_c <= l.max_valid_c;
  if (!plausible) {
    set_flag(flags_, kFlagTempInvalid, true);
    good_streak_ = 0;
    return false;
  }
  reading_since_tick_ = true;
  if (reading.temp_c >= l.over_temp_c) set_flag(flags_, kFlagOverTempLatched, true);
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
  if ((flags_ & kTempFaults) != 0) {
    const bool still_stuck = (flags_ & kFlagTempStuck) != 0 && reading.temp_c == stuck_value_c_;
    good_streak_ = still_stuck ? 0 : good_streak_ + 1;
    if (good_streak_ >= l.recovery_readings) {
      set_flag(flags_, kTempFaults, false);
      good_streak_ = 0;
    }
  }
  return true;
}

std::optional<double> FaultSupervisor::on_ambient_temperature(const hal::TemperatureReading& reading,
                                                              double now_s) noexcept {
  if (!ambient_expected_) {
    ambient_expected_ = true;
    ambient_time_s_ = now_s;  // staleness counts from the sensor's first report
  }
  if (!reading.valid || !std::isfinite(reading.temp_c) || reading.temp_c < limits_.min_valid_c ||
      reading.temp_c > limits_.max_valid_c) {
    return std::nullopt;
  }
  const double since_s = have_ambient_ ? now_s - ambient_time_s_ : 0.0;
  have_ambient_ = true;
  ambient_c_ = reading.temp_c;
  ambient_time_s_ = now_s;
  set_flag(flags_, kFlagAmbientStale, false);
  return since_s;
}

double FaultSupervisor::ambient_c() const noexcept {
  return have_ambient_ ? ambient_c_ : std::numeric_limits<double>::quiet_NaN();
}

void FaultSupervisor::on_opa548_thermal(bool in_shutdown, double now_s) noexcept {
  if (in_shutdown) {
    set_flag(flags_, kFlagOpa548Thermal, true);
    opa548_off_until_s_ = now_s + limits_.opa548_cooldown_s;
  } else if (now_s >= opa548_off_until_s_) {
    set_flag(flags_, kFlagOpa548Thermal, false);
  }
}

void FaultSupervisor::on_tec_write(bool ok) noexcept { set_flag(flags_, kFlagTecWriteFailed, !ok); }

void FaultSupervisor::record_command(double current_a) noexcept {
  drive_min_abs_a_ = std::min(drive_min_abs_a_, std::fabs(current_a));
  drive_lo_a_ = std::min(drive_lo_a_, current_a);
  drive_hi_a_ = std::max(drive_hi_a_, current_a);
}

void FaultSupervisor::on_reading_check(double surprise, double now_s) noexcept {
  if (!(surprise > limits_.stuck_sigma)) {
    surprised_ = false;
    return;
  }
  if (!surprised_) {
    surprised_ = true;
    surprised_since_s_ = now_s;
  }
  if (now_s - surprised_since_s_ >= limits_.stuck_sigma_s && raise_stuck()) surprised_ = false;
}

void FaultSupervisor::on_probe_failed() noexcept { raise_stuck(); }

void FaultSupervisor::on_loop_command(bool model_drove, double current_a, double setpoint_c, double now_s) noexcept {
  const double error_c = setpoint_c - casing_c_;
  // Heating above the setpoint or cooling below it (0 A opposes nothing).
  const bool opposes = model_drove && have_casing_ && current_a * error_c < 0.0;
  if (!opposes) {
    opposing_ = false;
    return;
  }
  if (!opposing_) {
    opposing_ = true;
    opposing_since_s_ = now_s;
    opposing_error_c_ = std::fabs(error_c);
  }
  if (now_s - opposing_since_s_ >= limits_.runaway_s &&
      std::fabs(error_c) - opposing_error_c_ >= limits_.runaway_c) {
    set_flag(flags_, kFlagLoopRunaway, true);
  }
}

void FaultSupervisor::clear_loop_runaway() noexcept {
  set_flag(flags_, kFlagLoopRunaway, false);
  opposing_ = false;
}

bool FaultSupervisor::raise_stuck() noexcept {
  if (!have_casing_ || (flags_ & kFlagTempStuck) != 0) return false;
  set_flag(flags_, kFlagTempStuck, true);
  // It clears once recovery_readings readings differ from this one.
  stuck_value_c_ = casing_c_;
  good_streak_ = 0;
  return true;
}

void FaultSupervisor::on_tick(double now_s, double period_s) noexcept {
  const auto& l = limits_;
  const bool stale = !have_casing_ || now_s - casing_time_s_ > l.stale_periods * period_s;
  if (stale && (flags_ & kFlagTempStale) == 0) {
    set_flag(flags_, kFlagTempStale, true);
    good_streak_ = 0;
  }
  const bool driving =
      drive_min_abs_a_ >= l.stuck_min_drive_a || (!model_check_ && drive_hi_a_ - drive_lo_a_ >= l.stuck_span_a);
  if (now_s - changed_at_s_ >= l.stuck_s && drive_hi_a_ >= drive_lo_a_ && driving) raise_stuck();
  if (!have_adc_time_) {  // the stall is counted from the first tick when no sample came yet
    have_adc_time_ = true;
    last_sample_s_ = now_s;
  }
  if (now_s - last_sample_s_ > l.adc_stall_s) set_flag(flags_, kFlagAdcStalled, true);
  if (ambient_expected_ && now_s - ambient_time_s_ > l.ambient_stale_s) set_flag(flags_, kFlagAmbientStale, true);
}

bool FaultSupervisor::take_new_reading() noexcept { return std::exchange(reading_since_tick_, false); }

}  // namespace gyrotc::app
