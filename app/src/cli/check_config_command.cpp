// `gyrotc check-config`: a configuration checked as `run` reads it (and the
// calibration and controller files it names), without opening any device.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/formats/calibration_in_use.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

const char* stream_name(StreamKind kind) {
  switch (kind) {
    case StreamKind::none: return "none";
    case StreamKind::stdout_stream: return "stdout";
    case StreamKind::file: return "file";
    case StreamKind::serial: return "serial";
  }
  return "?";
}

void check_config(const std::string& path) {
  const DaemonConfig config = load_daemon_config(path);
  const CalibrationInUse calibration = load_calibration_in_use(config.calibration_file);
  const fit::Compensator compensator(calibration.model, calibration.scale_mv_per_dps, calibration.die_lag_s);
  try {
    const Controller controller(config.controller, compensator);
    if (config.board.hal == HalKind::sim) model::validate(sim_plant_params(config.board));
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
  const ControllerConfig& c = config.controller;
  std::printf("%s: OK, as `gyrotc run` reads it (no device opened: `gyrotc probe` checks the board)\n", path.c_str());
  std::printf("  hal:         %s\n", config.board.hal == HalKind::sim ? "sim (the simulated board)" : "linux (the board's devices)");
  const char* loop = !c.pid_enabled ? "TEC off" : c.observer ? "model-based loop (type = \"observer\")" : "PID";
  std::printf("  control:     %s, setpoint %g C, period %g s, TEC %g .. %g A%s\n", loop, c.setpoint_c, c.pid.period_s,
              c.pid.out_min, c.pid.out_max,
              config.controller_file.empty() ? "" : (", controller file " + config.controller_file).c_str());
  if (c.observer) {
    // design_observer_loop refused an unstable one: these are below 1.
    std::printf("               %d states, stable at the design point: the filter's spectral radius %.4f, the "
                "loop's %.4f\n",
                c.observer->model.state_count(), c.observer->observer_radius, c.observer->loop_radius);
  }
  std::printf("  calibration: %s\n", describe(calibration).c_str());
  const OutputConfig& o = config.output;
  std::printf("  output:      stream %s, record %s, status %s, metrics %s\n", stream_name(o.stream),
              o.record_csv.empty() ? "off" : o.record_csv.c_str(), o.status_file.empty() ? "off" : o.status_file.c_str(),
              o.metrics_file.empty() ? "off" : o.metrics_file.c_str());
}

}  // namespace

void add_check_config_command(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "check-config",
      "Check a configuration file without touching the board: every key as `gyrotc run` reads it, the\n"
      "calibration and controller files it names, and (hal = \"sim\") the simulated plant. No device is\n"
      "opened, so it runs beside the service. Exit 0 and a summary when `run` would start with it; exit 1\n"
      "and one line naming the file, line and key when not.");
  cmd->add_option("FILE", *path, "configuration file (TOML), e.g. /etc/gyrotc/gyrotc.toml")->required();
  cmd->callback([path] {
    // Exit 1, not the input error's 2: here a bad file is the answer, not a misuse.
    try {
      check_config(*path);
    } catch (const InputError& e) {
      throw RuntimeFailure(e.what());
    }
  });
}

}  // namespace gyrotc::app
