#include "gyrotc/app/runtime/stuck_probe.hpp"

#include <cmath>
#include <utility>

namespace gyrotc::app {

void StuckProbe::start(Phase phase, double now_s, double reading_c, double setpoint_c) noexcept {
  // The loop holds its reading's expected value at its target: the target
  // past the step's edge, the reading must cross it.
  const double past_c = (0.5 + kMarginSteps) * kStepC;
  const double target_c = phase == Phase::up ? reading_c + past_c : reading_c - past_c;
  phase_ = phase;
  phase_start_s_ = now_s;
  offset_c_ = target_c - setpoint_c;
}

double StuckProbe::on_period(double now_s, double reading_c, double unchanged_s, double setpoint_c) noexcept {
  if (!(limits_.stuck_probe_s > 0.0) || !std::isfinite(reading_c) || !std::isfinite(setpoint_c)) {
    cancel();
    return offset_c_;
  }
  switch (phase_) {
    case Phase::idle:
      if (unchanged_s >= limits_.stuck_probe_s) {
        probe_start_s_ = now_s;
        start(Phase::up, now_s, reading_c, setpoint_c);
      }
      break;
    case Phase::up:
    case Phase::down:
      if (unchanged_s < now_s - probe_start_s_) {
        cancel();  // the reading followed: a live sensor
      } else if (now_s - phase_start_s_ >= limits_.stuck_probe_hold_s) {
        if (phase_ == Phase::up) {
          start(Phase::down, now_s, reading_c, setpoint_c);
        } else {
          cancel();
          failed_ = true;
        }
      }
      break;
  }
  return offset_c_;
}

void StuckProbe::cancel() noexcept {
  phase_ = Phase::idle;
  offset_c_ = 0.0;
}

bool StuckProbe::take_failed() noexcept { return std::exchange(failed_, false); }

}  // namespace gyrotc::app
