#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "gyrotc/app/runtime/controller.hpp"

// Controller file (TOML), what `gyrotc tune` writes and `gyrotc simulate
// --controller FILE`, `gyrotc run --controller FILE` and the daemon's
// [control] controller_file read:
//
//   format = "gyrotc-controller", version = 1
//   [control]    setpoint_c, kp, ki, kd, period_s, xi_c (required: the seed's
//                gain form of Eq. 17/18), feed_forward_a_per_c,
//                feed_forward_lag_s, setpoint_ramp_c_per_s (optional, default 0)
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
};

ControllerFile parse_controller_file(std::string_view text, const std::string& name);
ControllerFile load_controller_file(const std::string& path);

// The file's text; `informational` (TOML tables such as [identified] and
// [design]) is appended as it is.
std::string format_controller_file(const ControllerFile& file, const std::string& informational = {});
// RuntimeFailure when the file cannot be written.
void save_controller_file(const ControllerFile& file, const std::string& path, const std::string& informational = {});

// base with the file's controller: setpoint, gains, period, xi, feed-forward,
// setpoint ramp, rail limit and stuck drive; base keeps its output limits,
// rate output and other fail-safe limits. InputError (naming source) when the
// result cannot make a controller.
ControllerConfig apply_controller_file(const ControllerFile& file, ControllerConfig base, const std::string& source);

}  // namespace gyrotc::app
