#pragma once

// A TEC current programme that takes the PID's place for a while: the
// identification experiment of `gyrotc tune` (tune/experiment.hpp). The
// Controller asks it for the current every control period, after its
// fail-safe checks (a fault turns the TEC off and the programme is not asked),
// and clamps the answer to the limits it passes in. Implementations are
// real-time safe: next() does not allocate, lock or throw.
#include <limits>

namespace gyrotc::control {

struct TecProgramInput {
  double time_s = 0.0;      // since the programme's first period
  double casing_c = 0.0;    // last casing reading
  double ambient_c = 0.0;   // last ambient reading; NaN without an ambient sensor
  double setpoint_c = 0.0;  // the controller's setpoint
  double min_a = 0.0;       // the current the stage can apply now (limits and rails)
  double max_a = 0.0;
  // The gyro's mean output over the samples since the last period (NaN
  // without one), and its scale: what the self-calibration's dwells watch
  // settle.
  double gyro_mv = std::numeric_limits<double>::quiet_NaN();
  double gyro_scale_mv_per_dps = 1.0;
};

struct TecProgramOutput {
  double current_a = 0.0;
  bool finished = false;  // the programme is over: the TEC goes off and stays off
};

class TecProgram {
 public:
  virtual ~TecProgram() = default;

  TecProgramOutput next(const TecProgramInput& input) noexcept { return do_next(input); }

 private:
  virtual TecProgramOutput do_next(const TecProgramInput& input) noexcept = 0;
};

}  // namespace gyrotc::control
