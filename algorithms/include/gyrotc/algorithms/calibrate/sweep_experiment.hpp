#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "gyrotc/algorithms/control/tec_program.hpp"

// The self-calibration experiment of `gyrotc calibrate` (issue 30): with the
// gyro at rest, the unit's own bipolar TEC sweeps the casing through the
// temperatures a chamber would (seed Section 4), below and above the
// ambient, so the zero-bias curve can be measured in the field without a
// chamber. It runs through the Controller like the identification
// experiment (tune/experiment.hpp): on the board (`gyrotc record
// --experiment selfcal`, `gyrotc calibrate --config`) and in the simulator
// (`gyrotc simulate --profile selfcal`), under every fail-safe.
//
//   rest      TEC at 0 A: the starting casing temperature
//   down      a target ramps from there down to low_c at rate_c_per_min; a
//             PI tracks it
//   dwell_low the target held until the gyro's output settles: the die,
//             which lags the sensor, catches up
//   up        the ramp from the low end up to high_c
//   dwell_high
//   back      the ramp down to the starting temperature; then the TEC goes off
//
// Every temperature of the range is crossed once upwards and once downwards
// at the same rate, so the die's lag behind the sensor shifts the two passes
// by equal and opposite amounts and cancels in each temperature bin's mean
// (`gyrotc fit` bins the record; fit::screen_calibration_record judges a bin
// by its mean signed rate). Where the stage cannot follow the ramp (the
// current at its limit, the casing more than half a stall_c behind the
// target and less than a quarter of the ramp's way further after stall_s) that end
// is the end of the range: the range the stage reaches at the present
// ambient is found during the run. An end reached is the casing's extreme
// there (a casing that lags the target stops short of it).
namespace gyrotc::calibrate {

struct SweepRange {
  double low_c = 0.0;
  double high_c = 0.0;
};

struct SweepPlan {
  // The range asked for (casing, C). NaN: from below_ambient_c under the
  // ambient at the start (the casing's reading without an ambient sensor) to
  // above_setpoint_c over the controller's setpoint: what the unit sees in
  // service (it warms from the ambient to the setpoint) with a margin, so
  // the fit does not end at the edge of what it must compensate.
  double low_c = std::numeric_limits<double>::quiet_NaN();
  double high_c = std::numeric_limits<double>::quiet_NaN();
  double below_ambient_c = 12.0;
  double above_setpoint_c = 12.0;
  // Never past this (the app: [failsafe] over_temp_c less a margin).
  double ceiling_c = 75.0;
  double rate_c_per_min = 0.6;  // the ramps' rate
  double rest_s = 10.0;
  // Each end is held at least dwell_s (7 x the default plant's 40 s die time
  // constant), then until the gyro's output has settled: its linear trend
  // over the last settle_window_s moves it by at most settle_dps across the
  // window (the bias instability of a gyro of this class; its wander alone
  // passes within a few periods), and at most dwell_max_s (both ends held
  // that long keep the default sweep at 20 C ambient within 4 h). A slow
  // die, which the sensor does not show, is waited for; without gyro
  // samples the dwell is dwell_s.
  double dwell_s = 300.0;
  double dwell_max_s = 1200.0;
  double settle_window_s = 240.0;
  double settle_dps = 0.01;
  double track_kp_a_per_c = 0.2;
  double track_ki_a_per_c_s = 2e-3;
  double stall_c = 2.0;
  double stall_s = 300.0;

  SweepRange range(double ambient_c, double setpoint_c) const noexcept;
  // The longest the programme can run over `range`.
  double max_duration_s(const SweepRange& range) const noexcept;
};

// Throws std::invalid_argument naming the field.
void validate(const SweepPlan& plan);

// The sweep never goes within this of the controller's over-temperature
// fail-safe: the casing overshoots a ramp's end by a few tenths, and the
// fail-safe would end the run.
inline constexpr double kOverTempMarginC = 5.0;

// The default plan under a fail-safe at over_temp_c.
SweepPlan plan_below_over_temp(double over_temp_c);

enum class SweepPhase : std::uint8_t { rest, down, dwell_low, up, dwell_high, back, done };
const char* to_string(SweepPhase phase) noexcept;

class SweepExperiment final : public control::TecProgram {
 public:
  explicit SweepExperiment(const SweepPlan& plan = {});

  // Progress, readable from any thread while the runner's thread sweeps (the
  // board's status lines): the phase, the ends reached (NaN until the dwell
  // there is over: the casing's extreme at that end), the ramp's
  // target and the time left at the ramp's rate (an estimate: a stall or a
  // lagging casing adds to it).
  SweepPhase phase() const noexcept { return phase_.load(std::memory_order_relaxed); }
  double reached_low_c() const noexcept { return reached_low_c_.load(std::memory_order_relaxed); }
  double reached_high_c() const noexcept { return reached_high_c_.load(std::memory_order_relaxed); }
  double target_c() const noexcept { return target_shown_c_.load(std::memory_order_relaxed); }
  double remaining_s() const noexcept { return remaining_s_.load(std::memory_order_relaxed); }
  // How long each end was held (NaN until its dwell is over), and whether the
  // gyro settled in it (false: held dwell_max_s, or no gyro samples).
  double dwell_low_s() const noexcept { return dwell_low_s_.load(std::memory_order_relaxed); }
  double dwell_high_s() const noexcept { return dwell_high_s_.load(std::memory_order_relaxed); }
  bool settled_low() const noexcept { return settled_low_.load(std::memory_order_relaxed); }
  bool settled_high() const noexcept { return settled_high_.load(std::memory_order_relaxed); }
  // In a dwell, how far the gyro's output moved over the last
  // settle_window_s, deg/s (NaN until judged): why an end is still held.
  // After a dwell, the figure it turned at.
  double gyro_trend_dps() const noexcept { return gyro_trend_dps_.load(std::memory_order_relaxed); }

  const SweepPlan& plan() const noexcept { return plan_; }
  // The range asked for, once the rest is over (NaN before). The runner's
  // thread only.
  const SweepRange& range() const noexcept { return range_; }

 private:
  control::TecProgramOutput do_next(const control::TecProgramInput& in) noexcept override;
  void enter(SweepPhase phase, double time_s) noexcept;
  double track(const control::TecProgramInput& in, double dt_s) noexcept;
  bool stalled(const control::TecProgramInput& in, double direction, double dt_s) noexcept;
  void note_extreme(double casing_c, double direction) noexcept;
  void note_gyro(const control::TecProgramInput& in) noexcept;
  enum class Settling : std::uint8_t { settled, moving, unknown };
  Settling gyro_settling(const control::TecProgramInput& in, double& trend_dps) const noexcept;
  bool dwell_over(const control::TecProgramInput& in, bool& settled) noexcept;

  double estimate_remaining_s(double time_s) const noexcept;

  SweepPlan plan_;
  std::atomic<SweepPhase> phase_{SweepPhase::rest};
  double phase_start_s_ = 0.0;
  double last_time_s_ = 0.0;
  SweepRange range_;
  double start_c_ = 0.0;
  double target_c_ = 0.0;
  double integral_a_ = 0.0;
  double last_command_a_ = 0.0;
  double stall_time_s_ = 0.0;
  double stall_from_c_ = 0.0;  // the casing when the current stall began
  double extreme_c_ = 0.0;     // the casing's extreme since the ramp towards an end began
  struct GyroMean {
    double time_s = 0.0;
    double gyro_mv = 0.0;
  };
  // The gyro's recent means, oldest overwritten (a settle_window_s fits).
  std::array<GyroMean, 1024> gyro_{};
  std::size_t gyro_next_ = 0;
  std::size_t gyro_count_ = 0;
  double pool_start_s_ = 0.0;  // the periods' means pooled into the next point
  double pool_time_sum_s_ = 0.0;
  double pool_gyro_sum_mv_ = 0.0;
  double pool_count_ = 0.0;
  std::atomic<double> dwell_low_s_;
  std::atomic<double> dwell_high_s_;
  std::atomic<bool> settled_low_{false};
  std::atomic<bool> settled_high_{false};
  std::atomic<double> gyro_trend_dps_;
  std::atomic<double> reached_low_c_;
  std::atomic<double> reached_high_c_;
  std::atomic<double> target_shown_c_;
  std::atomic<double> remaining_s_;
};

}  // namespace gyrotc::calibrate
