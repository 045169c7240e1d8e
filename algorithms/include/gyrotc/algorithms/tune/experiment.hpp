#pragma once

#include <cstdint>
#include <string>

#include "gyrotc/algorithms/control/tec_program.hpp"

// The identification experiment of `gyrotc tune` (issue 23): a TEC current
// programme that runs the same through the Controller on the board (`gyrotc
// record --experiment tune`) and in the simulator (`gyrotc simulate --profile
// tune`), at whatever ambient the room or chamber holds, within the current
// the Controller allows (its limits and the OPA548 rails) and under all its
// fail-safes. Phases:
//
//   rest      TEC at 0 A: the unit's starting state
//   approach  full current towards the setpoint, until within approach_band_c
//             (the warm-up the controller will do, and where the rails clip)
//   relay     relay feedback around the setpoint, +/- relay_fraction of the
//             range around a bias that follows the mean current of the last
//             cycle (Astrom-Hagglund): the holding current and the loop's
//             fast dynamics (sensor, dead time)
//   prbs      a pseudo-random binary sequence of +/- prbs_fraction around the
//             holding current, under a gentle P + slow I hold so the casing
//             stays near the setpoint: the dynamics over minutes
//   coast     TEC at 0 A: the casing relaxes towards the ambient (its loss)
//   cool      full cooling current: the Peltier term against the Joule heat
//   reheat    full current back towards the setpoint (a second warm-up from a
//             different state), then the programme ends and the TEC goes off
//
// Every phase with a target has a timeout, so the whole programme is bounded
// by max_duration_s() (<= 3 h with the defaults: 2 h 35 min). If the casing
// leaves the setpoint by more than guard_c during relay or prbs, full current
// pushes it back first. If full current towards the setpoint moves the casing
// wrong_way_c away from it during the approach (a TEC wired the wrong way
// round), the programme ends there, the TEC off, in the phase wrong_way.
namespace gyrotc::tune {

struct ExperimentPlan {
  double rest_s = 10.0;
  double approach_timeout_s = 2700.0;
  double approach_band_c = 0.5;
  double relay_s = 1200.0;
  double relay_fraction = 0.5;
  double relay_hysteresis_c = 0.125;  // two DS18B20 steps
  double prbs_s = 2400.0;
  double prbs_bit_s = 20.0;
  double prbs_fraction = 0.4;
  double hold_kp_a_per_c = 0.2;       // the prbs phase's gentle hold
  double hold_ki_a_per_c_s = 5e-4;
  double guard_c = 2.0;
  double wrong_way_c = 2.0;  // beyond a sensor's lag behind a casing still drifting at the start
  double coast_s = 1200.0;
  double cool_s = 300.0;
  double reheat_timeout_s = 1500.0;

  double max_duration_s() const noexcept;
  // The same programme on a unit whose time constants are `factor` times
  // the reference unit's (a small board, a fast emulated plant): every
  // duration, timeout and the PRBS bit times factor, the hold's integral
  // gain divided by it. 0 < factor <= 1. What it costs: the phases see less
  // of whatever is slower than factor x the reference (the loss to the
  // ambient, the shell), so `gyrotc tune` reports wider standard errors for
  // those; the relay and PRBS, which see the loop's own dynamics, lose only
  // if those do not scale with the unit.
  ExperimentPlan scaled(double factor) const;
};

// Throws std::invalid_argument naming the field.
void validate(const ExperimentPlan& plan);

enum class ExperimentPhase : std::uint8_t { rest, approach, relay, prbs, coast, cool, reheat, done, wrong_way };
const char* to_string(ExperimentPhase phase) noexcept;

// What an experiment that ended in wrong_way tells its user, in one line.
std::string wrong_way_message(const ExperimentPlan& plan);

class IdentificationExperiment final : public control::TecProgram {
 public:
  explicit IdentificationExperiment(const ExperimentPlan& plan = {});

  ExperimentPhase phase() const noexcept { return phase_; }
  const ExperimentPlan& plan() const noexcept { return plan_; }

 private:
  control::TecProgramOutput do_next(const control::TecProgramInput& in) noexcept override;
  control::TecProgramOutput decide(const control::TecProgramInput& in) noexcept;
  void enter(ExperimentPhase phase, double time_s) noexcept;
  double relay(const control::TecProgramInput& in, double span_a) noexcept;
  double prbs(const control::TecProgramInput& in, double span_a, double h_s) noexcept;
  bool prbs_bit() noexcept;

  ExperimentPlan plan_;
  ExperimentPhase phase_ = ExperimentPhase::rest;
  double phase_start_s_ = 0.0;
  double last_time_s_ = 0.0;
  double last_command_a_ = 0.0;
  double direction_ = 1.0;  // +1: the setpoint is above the starting casing temperature
  double approach_start_c_ = 0.0;
  // relay
  bool relay_high_ = true;
  double bias_a_ = 0.0;
  double cycle_start_s_ = -1.0;
  double cycle_sum_a_s_ = 0.0;
  double cycle_time_s_ = 0.0;
  // prbs
  std::uint16_t lfsr_ = 0x1ff;
  bool bit_ = true;
  double next_bit_s_ = 0.0;
  double hold_integral_a_ = 0.0;
  int guard_ = 0;  // -1 / +1 while the guard pushes the casing back
};

}  // namespace gyrotc::tune
