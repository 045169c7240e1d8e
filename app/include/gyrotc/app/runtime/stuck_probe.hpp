#pragma once

// The active check of a casing reading the model-based loop holds on one
// step (issue 75, item 3; docs/FAULTS.md "A stuck casing sensor"). In the
// hold a frozen DS18B20 is invisible to any check that shares the loop's
// model: the loop holds on its model and the housing drifts by what the
// model gets wrong (32 C on one of the suite's network plants over the fig26
// programme). Once the reading has sat on one step for stuck_probe_s, the
// probe moves the loop's target just past the step's upper edge, then, if
// the reading did not follow within stuck_probe_hold_s, past its lower edge;
// a reading that follows neither is stuck. A healthy one changes and the
// target goes back: each probe lifts the hold by up to 3/4 of a step for up
// to stuck_probe_hold_s, which is why it is off by default (the nominal
// plant's in-band error 0.032 -> 0.043 C at stuck_probe_s = 300; FAULTS.md).
#include "gyrotc/app/runtime/fault_supervisor.hpp"

namespace gyrotc::app {

class StuckProbe {
 public:
  static constexpr double kMarginSteps = 0.25;  // past the edge by this much of a step
  static constexpr double kStepC = 0.0625;      // DS18B20 12-bit

  // limits: stuck_probe_s (0: off) and stuck_probe_hold_s, read at every period.
  explicit StuckProbe(const FailSafeLimits& limits) noexcept : limits_(limits) {}

  // Every period the model-based loop drove: the reading it held, how long
  // that reading has not changed, and the setpoint (the target without the
  // probe). Returns the offset to add to the loop's target from the next
  // period on.
  double on_period(double now_s, double reading_c, double unchanged_s, double setpoint_c) noexcept;
  // The loop did not drive this period (a fault, a programme): no probe.
  void cancel() noexcept;
  // Whether the last probe found the reading following neither edge (once).
  bool take_failed() noexcept;

  bool probing() const noexcept { return phase_ != Phase::idle; }
  double offset_c() const noexcept { return offset_c_; }

 private:
  enum class Phase { idle, up, down };
  void start(Phase phase, double now_s, double reading_c, double setpoint_c) noexcept;

  const FailSafeLimits& limits_;
  Phase phase_ = Phase::idle;
  double phase_start_s_ = 0.0;
  double probe_start_s_ = 0.0;  // the probe's first phase
  double offset_c_ = 0.0;
  bool failed_ = false;
};

}  // namespace gyrotc::app
