#include "gyrotc/algorithms/calibrate/sweep_experiment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace gyrotc::calibrate {

SweepRange SweepPlan::range(double ambient_c, double setpoint_c) const noexcept {
  SweepRange r;
  r.low_c = std::isnan(low_c) ? ambient_c - below_ambient_c : low_c;
  r.high_c = std::min(std::isnan(high_c) ? setpoint_c + above_setpoint_c : high_c, ceiling_c);
  return r;
}

double SweepPlan::max_duration_s(const SweepRange& r) const noexcept {
  // From anywhere in the range: down to the low end, up to the high end,
  // back; each end may add a stall before it is taken as the end.
  return rest_s + 2.0 * std::max(0.0, r.high_c - r.low_c) / (rate_c_per_min / 60.0) +
         2.0 * (std::max(dwell_s, dwell_max_s) + stall_s);
}

void validate(const SweepPlan& p) {
  auto require = [](bool ok, const char* field, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("sweep ") + field + " " + what);
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  require(!std::isinf(p.low_c), "low_c", "must be a temperature (or unset)");
  require(!std::isinf(p.high_c), "high_c", "must be a temperature (or unset)");
  require(std::isnan(p.low_c) || std::isnan(p.high_c) || p.high_c - p.low_c >= 5.0, "high_c",
          "must be at least 5 C above low_c");
  require(non_negative(p.below_ambient_c), "below_ambient_c", "must be zero or positive");
  require(non_negative(p.above_setpoint_c), "above_setpoint_c", "must be zero or positive");
  require(std::isfinite(p.ceiling_c), "ceiling_c", "must be a temperature");
  require(positive(p.rate_c_per_min) && p.rate_c_per_min <= 5.0, "rate_c_per_min", "must be within (0, 5]");
  require(non_negative(p.rest_s), "rest_s", "must be zero or positive");
  require(non_negative(p.dwell_s), "dwell_s", "must be zero or positive");
  require(std::isfinite(p.dwell_max_s) && p.dwell_max_s >= p.dwell_s, "dwell_max_s", "must be at least dwell_s");
  require(positive(p.settle_window_s) && p.settle_window_s <= 1800.0, "settle_window_s", "must be within (0, 1800] s");
  require(positive(p.settle_dps), "settle_dps", "must be positive");
  require(non_negative(p.track_kp_a_per_c), "track_kp_a_per_c", "must be zero or positive");
  require(positive(p.track_ki_a_per_c_s), "track_ki_a_per_c_s", "must be positive");
  require(positive(p.stall_c), "stall_c", "must be positive");
  require(positive(p.stall_s), "stall_s", "must be positive");
}

SweepPlan plan_below_over_temp(double over_temp_c) {
  SweepPlan plan;
  plan.ceiling_c = over_temp_c - kOverTempMarginC;
  return plan;
}

const char* to_string(SweepPhase phase) noexcept {
  switch (phase) {
    case SweepPhase::rest: return "rest";
    case SweepPhase::down: return "down";
    case SweepPhase::dwell_low: return "dwell_low";
    case SweepPhase::up: return "up";
    case SweepPhase::dwell_high: return "dwell_high";
    case SweepPhase::back: return "back";
    case SweepPhase::done: return "done";
  }
  return "?";
}

SweepExperiment::SweepExperiment(const SweepPlan& plan)
    : plan_(plan),
      dwell_low_s_(std::numeric_limits<double>::quiet_NaN()),
      dwell_high_s_(std::numeric_limits<double>::quiet_NaN()),
      gyro_trend_dps_(std::numeric_limits<double>::quiet_NaN()),
      reached_low_c_(std::numeric_limits<double>::quiet_NaN()),
      reached_high_c_(std::numeric_limits<double>::quiet_NaN()),
      target_shown_c_(std::numeric_limits<double>::quiet_NaN()),
      remaining_s_(std::numeric_limits<double>::quiet_NaN()) {
  range_.low_c = range_.high_c = std::numeric_limits<double>::quiet_NaN();
  validate(plan_);
}

void SweepExperiment::enter(SweepPhase phase, double time_s) noexcept {
  phase_.store(phase, std::memory_order_relaxed);
  phase_start_s_ = time_s;
  stall_time_s_ = 0.0;
  if (phase == SweepPhase::dwell_low || phase == SweepPhase::dwell_high) {
    gyro_trend_dps_.store(std::numeric_limits<double>::quiet_NaN(), std::memory_order_relaxed);
  }
}

void SweepExperiment::note_extreme(double casing_c, double direction) noexcept {
  if ((casing_c - extreme_c_) * direction > 0.0) extreme_c_ = casing_c;
}

// The periods' means pooled into points at least settle_window_s / 500
// apart, so the ring holds a whole window at any control period.
void SweepExperiment::note_gyro(const control::TecProgramInput& in) noexcept {
  if (!std::isfinite(in.gyro_mv)) return;
  pool_time_sum_s_ += in.time_s;
  pool_gyro_sum_mv_ += in.gyro_mv;
  pool_count_ += 1.0;
  if (in.time_s - pool_start_s_ < plan_.settle_window_s / 500.0) return;
  gyro_[gyro_next_] = {pool_time_sum_s_ / pool_count_, pool_gyro_sum_mv_ / pool_count_};
  gyro_next_ = (gyro_next_ + 1) % gyro_.size();
  gyro_count_ = std::min(gyro_count_ + 1, gyro_.size());
  pool_start_s_ = in.time_s;
  pool_time_sum_s_ = pool_gyro_sum_mv_ = pool_count_ = 0.0;
}

// The least-squares line through the gyro's means of the last
// settle_window_s of the dwell: settled when it moves the output by at most
// settle_dps over the window; not yet judged while the dwell is younger than
// the window; unknown when the window holds too few means (no samples).
SweepExperiment::Settling SweepExperiment::gyro_settling(const control::TecProgramInput& in,
                                                          double& trend_dps) const noexcept {
  trend_dps = std::numeric_limits<double>::quiet_NaN();
  if (in.time_s - phase_start_s_ < plan_.settle_window_s) return Settling::moving;
  const double from_s = in.time_s - plan_.settle_window_s;
  double n = 0.0, st = 0.0, sy = 0.0, stt = 0.0, sty = 0.0;
  for (std::size_t k = 0; k < gyro_count_; ++k) {
    const GyroMean& g = gyro_[(gyro_next_ + gyro_.size() - 1 - k) % gyro_.size()];
    if (g.time_s < from_s) break;
    const double t = g.time_s - in.time_s;
    n += 1.0;
    st += t;
    sy += g.gyro_mv;
    stt += t * t;
    sty += t * g.gyro_mv;
  }
  if (n < 10.0) return Settling::unknown;
  const double slope_mv_per_s = (n * sty - st * sy) / (n * stt - st * st);
  trend_dps = slope_mv_per_s * plan_.settle_window_s / in.gyro_scale_mv_per_dps;
  return std::fabs(trend_dps) <= plan_.settle_dps ? Settling::settled : Settling::moving;
}

// At least dwell_s; then until the gyro settles (settled: true), at most
// dwell_max_s, or at dwell_s when the gyro cannot be judged.
bool SweepExperiment::dwell_over(const control::TecProgramInput& in, bool& settled) noexcept {
  double trend_dps = 0.0;
  const Settling settling = gyro_settling(in, trend_dps);
  gyro_trend_dps_.store(trend_dps, std::memory_order_relaxed);
  const double held_s = in.time_s - phase_start_s_;
  if (held_s < plan_.dwell_s) return false;
  settled = settling == Settling::settled;
  return settling != Settling::moving || held_s >= plan_.dwell_max_s;
}

// PI on the moving target, integrating only while the output is not held at
// a limit in the error's direction (anti-windup).
double SweepExperiment::track(const control::TecProgramInput& in, double dt_s) noexcept {
  const double error_c = target_c_ - in.casing_c;
  const double unclamped = plan_.track_kp_a_per_c * error_c + integral_a_;
  const bool pushing_high = unclamped >= in.max_a && error_c > 0.0;
  const bool pushing_low = unclamped <= in.min_a && error_c < 0.0;
  if (!pushing_high && !pushing_low) integral_a_ += plan_.track_ki_a_per_c_s * error_c * dt_s;
  integral_a_ = std::clamp(integral_a_, in.min_a, in.max_a);
  return std::clamp(plan_.track_kp_a_per_c * error_c + integral_a_, in.min_a, in.max_a);
}

// The ramp's target waits while the casing is stall_c behind it (it never
// runs away from the casing, so the casing's rate stays at most the ramp's).
// The end is reached when the stage has been at its limit with the casing
// behind for stall_s and the casing went less than a quarter of the ramp's
// way in that time: a stage approaching its limit slows down long before it
// stops, so "stopped" would take hours to see. A casing approaching its
// limit with time constant tau stalls rate/4 x tau short of it.
bool SweepExperiment::stalled(const control::TecProgramInput& in, double direction, double dt_s) noexcept {
  const double behind_c = (target_c_ - in.casing_c) * direction;
  const double limit_a = direction > 0.0 ? in.max_a : in.min_a;
  const bool at_limit = std::fabs(last_command_a_ - limit_a) <= 1e-3 * std::max(1.0, std::fabs(limit_a));
  if (!(behind_c > 0.5 * plan_.stall_c && at_limit)) {
    stall_time_s_ = 0.0;
    return false;
  }
  if (stall_time_s_ == 0.0) stall_from_c_ = in.casing_c;
  stall_time_s_ += dt_s;
  if (stall_time_s_ < plan_.stall_s) return false;
  const double progress_c = (in.casing_c - stall_from_c_) * direction;
  if (progress_c < 0.25 * plan_.rate_c_per_min / 60.0 * stall_time_s_) return true;
  stall_time_s_ = 0.0;  // still following, if slowly: judge the next stall_s
  return false;
}

double SweepExperiment::estimate_remaining_s(double time_s) const noexcept {
  const double rate_c_per_s = plan_.rate_c_per_min / 60.0;
  const double low_c = std::isnan(reached_low_c()) ? range_.low_c : reached_low_c();
  const double high_c = std::isnan(reached_high_c()) ? range_.high_c : reached_high_c();
  const double dwell_left_s = std::max(0.0, plan_.dwell_s - (time_s - phase_start_s_));
  switch (phase()) {
    case SweepPhase::rest:
      return std::numeric_limits<double>::quiet_NaN();  // the range is not known yet
    case SweepPhase::down:
      return ((target_c_ - low_c) + (high_c - low_c) + (high_c - start_c_)) / rate_c_per_s + 2.0 * plan_.dwell_s;
    case SweepPhase::dwell_low:
      return dwell_left_s + (2.0 * high_c - low_c - start_c_) / rate_c_per_s + plan_.dwell_s;
    case SweepPhase::up:
      return (2.0 * high_c - target_c_ - start_c_) / rate_c_per_s + plan_.dwell_s;
    case SweepPhase::dwell_high:
      return dwell_left_s + (high_c - start_c_) / rate_c_per_s;
    case SweepPhase::back:
      return std::max(0.0, target_c_ - start_c_) / rate_c_per_s;
    case SweepPhase::done:
      return 0.0;
  }
  return 0.0;
}

control::TecProgramOutput SweepExperiment::do_next(const control::TecProgramInput& in) noexcept {
  const double dt_s = std::max(0.0, in.time_s - last_time_s_);
  last_time_s_ = in.time_s;
  note_gyro(in);
  const double rate_c_per_s = plan_.rate_c_per_min / 60.0;
  // One ramp step towards `end_c`; true once the target is there.
  auto ramp = [&](double end_c, double direction) {
    const double behind_c = (target_c_ - in.casing_c) * direction;
    if (behind_c <= plan_.stall_c) target_c_ += direction * rate_c_per_s * dt_s;
    if ((target_c_ - end_c) * direction >= 0.0) {
      target_c_ = end_c;
      return true;
    }
    return false;
  };

  switch (phase_.load(std::memory_order_relaxed)) {
    case SweepPhase::rest:
      if (in.time_s - phase_start_s_ >= plan_.rest_s) {
        range_ = plan_.range(std::isnan(in.ambient_c) ? in.casing_c : in.ambient_c, in.setpoint_c);
        if (!(range_.high_c - range_.low_c >= 5.0)) {
          // The ceiling is below the range's low end: nothing to sweep.
          enter(SweepPhase::done, in.time_s);
          last_command_a_ = 0.0;
          return {0.0, true};
        }
        start_c_ = std::clamp(in.casing_c, range_.low_c, range_.high_c);
        target_c_ = in.casing_c;
        extreme_c_ = in.casing_c;
        enter(SweepPhase::down, in.time_s);
      } else {
        last_command_a_ = 0.0;
        return {0.0, false};
      }
      break;
    case SweepPhase::down:
      note_extreme(in.casing_c, -1.0);
      if (ramp(range_.low_c, -1.0)) {
        enter(SweepPhase::dwell_low, in.time_s);
      } else if (stalled(in, -1.0, dt_s)) {
        target_c_ = in.casing_c;
        enter(SweepPhase::dwell_low, in.time_s);
      }
      break;
    case SweepPhase::dwell_low:
      note_extreme(in.casing_c, -1.0);
      if (bool settled = false; dwell_over(in, settled)) {
        settled_low_.store(settled, std::memory_order_relaxed);
        dwell_low_s_.store(in.time_s - phase_start_s_, std::memory_order_relaxed);
        reached_low_c_.store(extreme_c_, std::memory_order_relaxed);
        enter(SweepPhase::up, in.time_s);
      }
      break;
    case SweepPhase::up:
      note_extreme(in.casing_c, 1.0);
      if (ramp(range_.high_c, 1.0)) {
        enter(SweepPhase::dwell_high, in.time_s);
      } else if (stalled(in, 1.0, dt_s)) {
        target_c_ = in.casing_c;
        enter(SweepPhase::dwell_high, in.time_s);
      }
      break;
    case SweepPhase::dwell_high:
      note_extreme(in.casing_c, 1.0);
      if (bool settled = false; dwell_over(in, settled)) {
        settled_high_.store(settled, std::memory_order_relaxed);
        dwell_high_s_.store(in.time_s - phase_start_s_, std::memory_order_relaxed);
        reached_high_c_.store(extreme_c_, std::memory_order_relaxed);
        start_c_ = std::clamp(start_c_, reached_low_c(), reached_high_c());
        enter(SweepPhase::back, in.time_s);
      }
      break;
    case SweepPhase::back:
      if (ramp(start_c_, -1.0) || stalled(in, -1.0, dt_s)) enter(SweepPhase::done, in.time_s);
      break;
    case SweepPhase::done:
      break;
  }
  if (phase() == SweepPhase::done) {
    last_command_a_ = 0.0;
    remaining_s_.store(0.0, std::memory_order_relaxed);
    return {0.0, true};
  }
  target_shown_c_.store(target_c_, std::memory_order_relaxed);
  remaining_s_.store(estimate_remaining_s(in.time_s), std::memory_order_relaxed);
  last_command_a_ = track(in, dt_s);
  return {last_command_a_, false};
}

}  // namespace gyrotc::calibrate
