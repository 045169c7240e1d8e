#include "gyrotc/algorithms/tune/experiment.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/text/printf_string.hpp"

namespace gyrotc::tune {

double ExperimentPlan::max_duration_s() const noexcept {
  return rest_s + approach_timeout_s + relay_s + prbs_s + coast_s + cool_s + reheat_timeout_s;
}

ExperimentPlan ExperimentPlan::scaled(double factor) const {
  if (!(factor > 0.0 && factor <= 1.0)) {
    throw std::invalid_argument("experiment time scale must be within (0, 1], got " + std::to_string(factor));
  }
  ExperimentPlan p = *this;
  for (double* d : {&p.rest_s, &p.approach_timeout_s, &p.relay_s, &p.prbs_s, &p.prbs_bit_s, &p.coast_s, &p.cool_s,
                    &p.reheat_timeout_s}) {
    *d *= factor;
  }
  p.hold_ki_a_per_c_s /= factor;
  return p;
}

void validate(const ExperimentPlan& p) {
  auto require = [](bool ok, const char* field, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("experiment ") + field + " " + what);
  };
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  require(non_negative(p.rest_s), "rest_s", "must be zero or positive");
  require(positive(p.approach_timeout_s), "approach_timeout_s", "must be positive");
  require(positive(p.approach_band_c), "approach_band_c", "must be positive");
  require(non_negative(p.relay_s), "relay_s", "must be zero or positive");
  require(positive(p.relay_fraction) && p.relay_fraction <= 1.0, "relay_fraction", "must be within (0, 1]");
  require(non_negative(p.relay_hysteresis_c), "relay_hysteresis_c", "must be zero or positive");
  require(non_negative(p.prbs_s), "prbs_s", "must be zero or positive");
  require(positive(p.prbs_bit_s), "prbs_bit_s", "must be positive");
  require(positive(p.prbs_fraction) && p.prbs_fraction <= 1.0, "prbs_fraction", "must be within (0, 1]");
  require(non_negative(p.hold_kp_a_per_c), "hold_kp_a_per_c", "must be zero or positive");
  require(non_negative(p.hold_ki_a_per_c_s), "hold_ki_a_per_c_s", "must be zero or positive");
  require(positive(p.guard_c), "guard_c", "must be positive");
  require(positive(p.wrong_way_c), "wrong_way_c", "must be positive");
  require(non_negative(p.coast_s), "coast_s", "must be zero or positive");
  require(non_negative(p.cool_s), "cool_s", "must be zero or positive");
  require(positive(p.reheat_timeout_s), "reheat_timeout_s", "must be positive");
}

const char* to_string(ExperimentPhase phase) noexcept {
  switch (phase) {
    case ExperimentPhase::rest: return "rest";
    case ExperimentPhase::approach: return "approach";
    case ExperimentPhase::relay: return "relay";
    case ExperimentPhase::prbs: return "prbs";
    case ExperimentPhase::coast: return "coast";
    case ExperimentPhase::cool: return "cool";
    case ExperimentPhase::reheat: return "reheat";
    case ExperimentPhase::wrong_way: return "wrong_way";
    case ExperimentPhase::done: return "done";
  }
  return "?";
}

std::string wrong_way_message(const ExperimentPlan& plan) {
  return text::printf_string(
      "the identification experiment stopped in its approach: full current towards the setpoint moved the casing "
      "%.1f C away from it, so the TEC is wired the wrong way round (swap its leads at the OPA548's output) and the "
      "TEC is off; nothing to tune from this record",
      plan.wrong_way_c);
}

IdentificationExperiment::IdentificationExperiment(const ExperimentPlan& plan) : plan_(plan) { validate(plan_); }

void IdentificationExperiment::enter(ExperimentPhase phase, double time_s) noexcept {
  phase_ = phase;
  phase_start_s_ = time_s;
}

bool IdentificationExperiment::prbs_bit() noexcept {
  // 9-bit maximal-length LFSR (x^9 + x^5 + 1): period 511 bits.
  const auto feedback = static_cast<std::uint16_t>(((lfsr_ >> 8) ^ (lfsr_ >> 4)) & 1u);
  lfsr_ = static_cast<std::uint16_t>(((lfsr_ << 1) | feedback) & 0x1ffu);
  return feedback != 0;
}

double IdentificationExperiment::relay(const control::TecProgramInput& in, double span_a) noexcept {
  const double h = plan_.relay_hysteresis_c;
  const double error_c = (in.setpoint_c - in.casing_c) * direction_;
  if (relay_high_ && error_c < -h) {
    relay_high_ = false;
  } else if (!relay_high_ && error_c > h) {
    relay_high_ = true;
    // A cycle ends where the relay turns towards the setpoint again: the
    // bias becomes the mean current of that cycle (a symmetric relay).
    if (cycle_start_s_ >= 0.0 && cycle_time_s_ > 0.0) bias_a_ = cycle_sum_a_s_ / cycle_time_s_;
    cycle_start_s_ = in.time_s;
    cycle_sum_a_s_ = 0.0;
    cycle_time_s_ = 0.0;
  }
  const double d = plan_.relay_fraction * span_a;
  bias_a_ = std::clamp(bias_a_, in.min_a + d, in.max_a - d);
  return bias_a_ + (relay_high_ ? d : -d) * direction_;
}

double IdentificationExperiment::prbs(const control::TecProgramInput& in, double span_a, double h_s) noexcept {
  const double error_c = in.setpoint_c - in.casing_c;
  if (guard_ == 0 && std::fabs(error_c) > plan_.guard_c) guard_ = error_c > 0.0 ? 1 : -1;
  if (guard_ != 0 && error_c * guard_ <= 0.0) guard_ = 0;
  if (guard_ > 0) return in.max_a;
  if (guard_ < 0) return in.min_a;
  if (in.time_s >= next_bit_s_) {
    bit_ = prbs_bit();
    next_bit_s_ = in.time_s + plan_.prbs_bit_s;
  }
  hold_integral_a_ += plan_.hold_ki_a_per_c_s * error_c * h_s;
  hold_integral_a_ = std::clamp(hold_integral_a_, in.min_a, in.max_a);
  const double a = plan_.prbs_fraction * span_a;
  return hold_integral_a_ + plan_.hold_kp_a_per_c * error_c + (bit_ ? a : -a);
}

control::TecProgramOutput IdentificationExperiment::do_next(const control::TecProgramInput& in) noexcept {
  const control::TecProgramOutput out = decide(in);
  last_command_a_ = std::clamp(out.current_a, in.min_a, in.max_a);
  return out;
}

control::TecProgramOutput IdentificationExperiment::decide(const control::TecProgramInput& in) noexcept {
  const double t = in.time_s;
  const double h_s = std::max(0.0, t - last_time_s_);
  last_time_s_ = t;
  const double up_a = std::max(in.max_a, 0.0);
  const double down_a = std::max(-in.min_a, 0.0);
  const double span_a = std::min(up_a, down_a) > 0.0 ? std::min(up_a, down_a) : std::max(up_a, down_a);
  const double toward_a = direction_ > 0.0 ? in.max_a : in.min_a;
  const double away_a = direction_ > 0.0 ? in.min_a : in.max_a;
  const double elapsed_s = t - phase_start_s_;
  const bool near = (in.setpoint_c - in.casing_c) * direction_ <= plan_.approach_band_c;

  switch (phase_) {
    case ExperimentPhase::rest:
      if (elapsed_s < plan_.rest_s) return {0.0, false};
      direction_ = in.casing_c <= in.setpoint_c ? 1.0 : -1.0;
      approach_start_c_ = in.casing_c;
      enter(ExperimentPhase::approach, t);
      return decide(in);
    case ExperimentPhase::approach:
      if ((in.casing_c - approach_start_c_) * direction_ <= -plan_.wrong_way_c) {
        enter(ExperimentPhase::wrong_way, t);
        return {0.0, true};
      }
      if (!near && elapsed_s < plan_.approach_timeout_s) return {toward_a, false};
      enter(ExperimentPhase::relay, t);
      relay_high_ = (in.setpoint_c - in.casing_c) * direction_ > 0.0;
      return {relay(in, span_a), false};
    case ExperimentPhase::relay: {
      // The current applied since the last period counts towards the cycle's mean.
      cycle_sum_a_s_ += h_s * last_command_a_;
      cycle_time_s_ += h_s;
      if (elapsed_s < plan_.relay_s) return {relay(in, span_a), false};
      enter(ExperimentPhase::prbs, t);
      hold_integral_a_ = bias_a_;
      next_bit_s_ = t;
      return {prbs(in, span_a, 0.0), false};
    }
    case ExperimentPhase::prbs:
      if (elapsed_s < plan_.prbs_s) return {prbs(in, span_a, h_s), false};
      enter(ExperimentPhase::coast, t);
      return {0.0, false};
    case ExperimentPhase::coast:
      if (elapsed_s < plan_.coast_s) return {0.0, false};
      enter(ExperimentPhase::cool, t);
      return {away_a, false};
    case ExperimentPhase::cool:
      if (elapsed_s < plan_.cool_s) return {away_a, false};
      enter(ExperimentPhase::reheat, t);
      return {toward_a, false};
    case ExperimentPhase::reheat:
      if (!near && elapsed_s < plan_.reheat_timeout_s) return {toward_a, false};
      enter(ExperimentPhase::done, t);
      return {0.0, true};
    case ExperimentPhase::done:
    case ExperimentPhase::wrong_way: return {0.0, true};
  }
  return {0.0, true};
}

}  // namespace gyrotc::tune
