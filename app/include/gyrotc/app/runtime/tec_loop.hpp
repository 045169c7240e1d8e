#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/control/pid.hpp"
#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/control/tec_program.hpp"

// The Controller's TEC loop: the period's current from the casing reading,
// the PID (seed Eq. 17/18) with the tuned options, the model-based loop
// (control/observer_loop.hpp) when the configuration has one, or a TEC
// programme in their place; off, held, or restarted as the Controller
// decides from its fault supervisor. Owns the flags tec_off and
// tec_saturated.
namespace gyrotc::app {

struct ControllerConfig;

struct TecCommand {
  double current_a = 0.0;
  bool enable = false;
  std::uint32_t flags = 0;
};

// What the model-based loop estimates after its last period; NaN with the
// PID or a programme, and before the loop's first period.
struct LoopEstimate {
  double held_c = std::numeric_limits<double>::quiet_NaN();     // the temperature the loop holds (its sensor's node)
  double ambient_c = std::numeric_limits<double>::quiet_NaN();  // the ambient the housing sees
  // The current that holds the setpoint against the estimated heat and ambient.
  double holding_a = std::numeric_limits<double>::quiet_NaN();
};

class TecLoop {
 public:
  // `config` is the Controller's, read at every period (a reload changes it).
  explicit TecLoop(const ControllerConfig& config);

  // TEC off. With `resume`, the PID (if it was running) restarts with the
  // integral it has now (IncrementalPid::integral); without, from 0 A.
  const TecCommand& off(double now_s, bool resume) noexcept;
  // The last current again (a period without news, not yet stale).
  const TecCommand& hold(double now_s) noexcept;
  // The PID's (or the model-based loop's) period, started or restarted as
  // off() left it; casing_age_s: how long ago the casing reading was measured.
  const TecCommand& pid_tick(double now_s, double casing_c, double ambient_c, double casing_age_s = 0.0) noexcept;
  // The programme's period; off when it says it has finished.
  const TecCommand& program_tick(double now_s, double casing_c, double ambient_c, double gyro_scale_mv_per_dps) noexcept;

  // A new ambient reading, `since_s` after the last, for the feed-forward's lag.
  void on_ambient(double ambient_c, double since_s) noexcept;
  // A gyro sample for the programme's mean (while one runs).
  void on_gyro_sample(double gyro_mv) noexcept;
  void run_program(control::TecProgram* program) noexcept;
  bool program_running() const noexcept { return program_ != nullptr; }
  bool program_finished() const noexcept { return program_finished_.load(std::memory_order_acquire); }
  // New PID parameters from the next period on (the Controller's reload).
  void retune(const control::PidParams& pid) noexcept;
  // Another model-based loop (nullptr: the PID) from the next period on (the
  // Controller's reload). While the TEC drives, the new loop takes over from
  // where the running one leaves the housing, without a kick
  // (control::ObserverLoop::adopt; the PID with its integral at the current
  // applied). `next` is built off this thread and outlives its use here.
  void switch_observer(control::ObserverLoop* next) noexcept;
  // The PID in the model-based loop's place from the next period on (a
  // runaway), its integral from 0 A: what that loop learnt of the load is
  // what went wrong. Nothing with the PID already.
  void fall_back_to_pid() noexcept;

  bool pid_running() const noexcept { return pid_running_; }
  // Whether a restart continues with the integral a fault stopped the PID at.
  bool resuming() const noexcept { return resume_; }
  double active_setpoint_c() const noexcept { return active_setpoint_c_; }
  const TecCommand& last_command() const noexcept { return command_; }
  // The whole flag word in the last command (the Controller's, after a period).
  void set_command_flags(std::uint32_t flags) noexcept { command_.flags = flags; }
  std::uint32_t flags() const noexcept { return flags_; }
  LoopEstimate estimate() const noexcept;
  // The model-based loop's check of this period's casing reading
  // (control::ObserverLoop::reading_surprise); 0 with the PID, a programme,
  // or a period the loop did not run.
  double reading_surprise() const noexcept { return reading_surprise_; }
  // Whether the model-based loop drove this period.
  bool model_drove() const noexcept { return model_drove_; }
  // An offset to the model-based loop's target from the next period on (the stuck probe's).
  void set_target_offset_c(double offset_c) noexcept { target_offset_c_ = offset_c; }

 private:
  const TecCommand& drive(double current_a, bool saturated, double now_s) noexcept;
  // The current the stage can apply now: out_min/out_max within the rails.
  control::CurrentRange applied_range(double casing_c, double ambient_c) const noexcept;
  // The PID's feed-forward now: the setpoint against the lagged ambient.
  double feed_forward_a() const noexcept;

  const ControllerConfig& config_;
  control::IncrementalPid pid_;
  control::ObserverLoop* observer_ = nullptr;  // the model-based loop in use: own_observer_, or a reload's
  std::optional<control::ObserverLoop> own_observer_;
  double last_casing_c_ = std::numeric_limits<double>::quiet_NaN();   // the last period's casing reading
  double last_ambient_c_ = std::numeric_limits<double>::quiet_NaN();  // the last ambient reading
  std::uint32_t flags_;
  bool pid_running_ = false;
  bool resume_ = false;              // the next start continues the PID where a fault stopped it
  double resume_integral_a_ = 0.0;   // the PID integral to restart with
  control::AmbientLag ff_ambient_;   // what the feed-forward answers
  double new_ambient_c_ = std::numeric_limits<double>::quiet_NaN();  // an ambient reading since the last period
  control::TecProgram* program_ = nullptr;
  bool program_started_ = false;
  double program_start_s_ = 0.0;
  double program_gyro_sum_mv_ = 0.0;  // the samples since the programme's last period
  std::size_t program_gyro_count_ = 0;
  std::atomic<bool> program_finished_{false};
  double active_setpoint_c_;
  double last_tick_s_ = 0.0;
  double reading_surprise_ = 0.0;
  bool model_drove_ = false;
  double target_offset_c_ = 0.0;
  TecCommand command_;
};

}  // namespace gyrotc::app
