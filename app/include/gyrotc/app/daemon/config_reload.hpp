#pragma once

#include <toml++/toml.h>

#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/session.hpp"
#include "gyrotc/app/formats/calibration_in_use.hpp"

// SIGHUP (systemctl reload gyrotc): the configuration file read again, and
// what of it a running daemon can take without stopping the TEC loop.
namespace gyrotc::app {

// The "section.key" paths whose values differ between two versions of a
// configuration (added and removed keys too), in file order.
std::vector<std::string> changed_keys(const toml::table& before, const toml::table& after);

// A key SIGHUP applies: [control]'s setpoint, gains, period, band, limits,
// pid, feed-forward, ramp and controller_file; [calibration] file; [output]
// except period_s (the runner's averaging period). Every other key (the
// board's wiring, the HAL, [tec], [sim], [realtime], [failsafe], the output
// period, the sensor period and the rate output) takes a restart.
bool reloadable_key(std::string_view key);

struct ReloadPlan {
  DaemonConfig config;                    // the file as read now, the command line's overrides applied
  CalibrationInUse calibration;           // its calibration, loaded
  std::vector<std::string> restart_keys;  // changed since the start, not applied: a restart takes them
};

// Reads the configuration and the files it names as `gyrotc run` would at a
// start, with the command line's --controller and --pid over it, and lists
// the keys changed since `running` that need a restart. Throws InputError
// naming the file, line and key: then nothing is applied.
ReloadPlan plan_reload(const SessionOptions& options, const toml::table& running);

}  // namespace gyrotc::app
