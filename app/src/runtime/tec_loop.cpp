#include "gyrotc/app/runtime/tec_loop.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/runtime/controller_flags.hpp"

namespace gyrotc::app {

TecLoop::TecLoop(const ControllerConfig& config)
    : config_(config), pid_(config.pid), flags_(kFlagTecOff), active_setpoint_c_(config.setpoint_c) {
  if (config.observer) observer_ = &own_observer_.emplace(config.observer);
}

void TecLoop::switch_observer(control::ObserverLoop* next) noexcept {
  if (next == observer_) return;
  const bool driving = pid_running_ && command_.enable && program_ == nullptr;
  if (driving && next != nullptr) {
    next->adopt(observer_ != nullptr && observer_->started()
                    ? observer_->handover()
                    : control::LoopHandover{last_casing_c_, last_ambient_c_, command_.current_a});
  } else if (driving) {
    // To the PID: its integral part starts at the current applied (less the
    // feed-forward it adds), its proportional part on the error then.
    pid_.reset(command_.current_a - feed_forward_a());
  }
  observer_ = next;
}

void TecLoop::fall_back_to_pid() noexcept {
  if (observer_ == nullptr) return;
  observer_ = nullptr;
  pid_.reset(0.0);
  resume_integral_a_ = 0.0;
}

const TecCommand& TecLoop::off(double now_s, bool resume) noexcept {
  // The model-based loop's filter follows the housing through the stop
  // (0 A: the TEC is off), so that a restart does not start it anew.
  if (observer_) observer_->coast(0.0);
  reading_surprise_ = 0.0;
  model_drove_ = false;
  set_flag(flags_, kFlagTecOff, true);
  set_flag(flags_, kFlagTecSaturated, false);
  if (pid_running_) {
    resume_ = resume;
    resume_integral_a_ = resume ? pid_.integral() : 0.0;
    // The model-based loop's integral is its estimate of the unknown heat.
    if (observer_) observer_->restart(resume);
  }
  pid_running_ = false;
  pid_.reset(0.0);
  command_ = TecCommand{0.0, false, flags_};
  last_tick_s_ = now_s;
  return command_;
}

const TecCommand& TecLoop::hold(double now_s) noexcept {
  if (observer_) observer_->coast(command_.enable ? command_.current_a : 0.0);
  reading_surprise_ = 0.0;
  model_drove_ = false;
  command_.flags = flags_;
  last_tick_s_ = now_s;
  return command_;
}

const TecCommand& TecLoop::drive(double current_a, bool saturated, double now_s) noexcept {
  set_flag(flags_, kFlagTecOff, false);
  set_flag(flags_, kFlagTecSaturated, saturated);
  command_ = TecCommand{current_a, true, flags_};
  last_tick_s_ = now_s;
  return command_;
}

const TecCommand& TecLoop::pid_tick(double now_s, double casing_c, double ambient_c, double casing_age_s) noexcept {
  const double dt_s = pid_running_ ? now_s - last_tick_s_ : 0.0;
  last_casing_c_ = casing_c;
  if (!pid_running_) {
    // After a sensor fault (stale) or a dead ADC the PID restarts with the
    // integral it had (what it learnt of the load), its proportional part on
    // the error now: a casing that cooled while the TEC was off is heated
    // back (IncrementalPid::integral). After any other stop it starts from
    // 0 A. No derivative kick either way.
    pid_.reset(resume_ ? resume_integral_a_ : 0.0);
    resume_ = false;
    resume_integral_a_ = 0.0;
    active_setpoint_c_ = config_.setpoint_ramp_c_per_s > 0.0 ? casing_c : config_.setpoint_c;
    pid_running_ = true;
  }
  if (config_.setpoint_ramp_c_per_s > 0.0) {
    const double step = config_.setpoint_ramp_c_per_s * dt_s;
    active_setpoint_c_ += std::clamp(config_.setpoint_c - active_setpoint_c_, -step, step);
  } else {
    active_setpoint_c_ = config_.setpoint_c;
  }
  if (observer_) {
    const control::CurrentRange range = applied_range(casing_c, ambient_c);
    const double current_a = observer_->tick(casing_c, casing_age_s, new_ambient_c_,
                                             active_setpoint_c_ + target_offset_c_, range.min_a, range.max_a);
    new_ambient_c_ = std::numeric_limits<double>::quiet_NaN();
    reading_surprise_ = observer_->reading_surprise();
    model_drove_ = true;
    return drive(current_a, observer_->saturated(), now_s);
  }
  const double ff = feed_forward_a();
  // Anti-windup on the current applied (issue 22): control/tec_law.hpp.
  const double current_a =
      control::pid_current_a(pid_, casing_c, active_setpoint_c_, ff, applied_range(casing_c, ambient_c));
  return drive(current_a, pid_.saturated(), now_s);
}

const TecCommand& TecLoop::program_tick(double now_s, double casing_c, double ambient_c,
                                        double gyro_scale_mv_per_dps) noexcept {
  if (!program_started_) {
    program_started_ = true;
    program_start_s_ = now_s;
  }
  control::TecProgramInput in;
  reading_surprise_ = 0.0;
  model_drove_ = false;
  in.time_s = now_s - program_start_s_;
  in.casing_c = casing_c;
  in.ambient_c = ambient_c;
  in.setpoint_c = config_.setpoint_c;
  const control::CurrentRange range = applied_range(casing_c, ambient_c);
  in.min_a = range.min_a;
  in.max_a = range.max_a;
  in.gyro_mv = program_gyro_count_ > 0 ? program_gyro_sum_mv_ / static_cast<double>(program_gyro_count_)
                                        : std::numeric_limits<double>::quiet_NaN();
  in.gyro_scale_mv_per_dps = gyro_scale_mv_per_dps;
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

LoopEstimate TecLoop::estimate() const noexcept {
  if (!observer_ || !observer_->started() || program_ != nullptr) return {};
  return {observer_->controlled_estimate_c(), observer_->ambient_estimate_c(), observer_->holding_current_a()};
}

double TecLoop::feed_forward_a() const noexcept {
  return control::feed_forward_a(config_.feed_forward_a_per_c, config_.setpoint_c, ff_ambient_.value_c());
}

control::CurrentRange TecLoop::applied_range(double casing_c, double ambient_c) const noexcept {
  return control::applied_range(config_.pid.out_min, config_.pid.out_max, config_.rail, casing_c, ambient_c);
}

void TecLoop::on_ambient(double ambient_c, double since_s) noexcept {
  ff_ambient_.update(ambient_c, since_s, config_.feed_forward_lag_s);
  new_ambient_c_ = ambient_c;
  last_ambient_c_ = ambient_c;
}

void TecLoop::on_gyro_sample(double gyro_mv) noexcept {
  program_gyro_sum_mv_ += gyro_mv;
  ++program_gyro_count_;
}

void TecLoop::run_program(control::TecProgram* program) noexcept {
  program_ = program;
  program_started_ = false;
  program_gyro_sum_mv_ = 0.0;
  program_gyro_count_ = 0;
  program_finished_.store(false, std::memory_order_release);
  pid_running_ = false;
}

void TecLoop::retune(const control::PidParams& pid) noexcept {
  pid_.retune(pid);
  resume_integral_a_ = std::clamp(resume_integral_a_, pid.out_min, pid.out_max);
}

}  // namespace gyrotc::app
