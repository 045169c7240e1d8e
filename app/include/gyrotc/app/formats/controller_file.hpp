#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"
#include "gyrotc/app/runtime/controller.hpp"

// Controller file (TOML), what `gyrotc tune` writes and `gyrotc simulate
// --controller FILE`, `gyrotc run --controller FILE` and the daemon's
// [control] controller_file read:
//
//   format = "gyrotc-controller", version = 1 or 2
//   type         "pid" (the default) or "observer" (version 2: the model-based
//                loop, control/observer_loop.hpp)
//   [control]    setpoint_c, kp, ki, kd, period_s, xi_c (required: the seed's
//                gain form of Eq. 17/18), feed_forward_a_per_c,
//                feed_forward_lag_s, setpoint_ramp_c_per_s (optional, default 0);
//                type "observer": setpoint_c and period_s only
//   [model]      type "observer": the identified housing (tune/thermal_model.hpp,
//                per unit of the casing's heat capacity), required
//   [observer]   type "observer": the filter's noises and the LQ weights
//                (tune/identified_housing.hpp), required
//   [rail]       pos_a, neg_a, a_per_c: the OPA548 stage's rail limit
//                (ControllerConfig::rail); optional
//   [failsafe]   stuck_min_drive_a (optional)
//   [identified], [design]  what tune found and why it chose these numbers;
//                informational, not read
//
// The file sets the controller, not the board: the TEC current limits, the
// rate output and the other fail-safe limits stay those of the configuration
// (or of the simulated plant). Errors are InputErrors naming the file, the
// line and the key.
namespace gyrotc::app {

// The model-based loop a controller file carries: the loop is designed from
// these when the file is applied (the same numbers give the same loop).
struct ObserverLoopFile {
  tune::ThermalModel model;
  // Its heats (initial_heat_w, disturbance_w_per_sqrt_s) are in kelvin per
  // second of the casing, as the model's; setpoint_c and period_s are the
  // file's [control].
  control::ObserverLoopSpec spec;
};

struct ControllerFile {
  double setpoint_c = 55.0;
  double kp = 0.48;
  double ki = 0.32;
  double kd = 10.0;
  double period_s = 2.0;
  double xi_c = 0.5;
  double feed_forward_a_per_c = 0.0;
  double feed_forward_lag_s = 0.0;
  double setpoint_ramp_c_per_s = 0.0;
  RailLimit rail;
  std::optional<double> stuck_min_drive_a;
  std::optional<ObserverLoopFile> observer;  // type = "observer"
};

ControllerFile parse_controller_file(std::string_view text, const std::string& name);
ControllerFile load_controller_file(const std::string& path);

// The file's text; `informational` (TOML tables such as [identified] and
// [design]) is appended as it is.
std::string format_controller_file(const ControllerFile& file, const std::string& informational = {});
// RuntimeFailure when the file cannot be written.
void save_controller_file(const ControllerFile& file, const std::string& path, const std::string& informational = {});

// base with the file's controller: setpoint, gains, period, xi, feed-forward,
// setpoint ramp, rail limit and stuck drive, or the model-based loop designed
// from the file's model for base's current limits; base keeps its output
// limits, rate output and other fail-safe limits. InputError (naming source)
// when the result cannot make a controller (a model-based loop that is not
// stable says so, with its spectral radii).
ControllerConfig apply_controller_file(const ControllerFile& file, ControllerConfig base, const std::string& source);

}  // namespace gyrotc::app
