// `gyrotc record`: the raw data a calibration needs, from the running board.
#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/session.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

void add_record_command(CLI::App& app) {
  auto options = std::make_shared<SessionOptions>();
  auto pid = std::make_shared<std::string>();
  options->config_path = "/etc/gyrotc/gyrotc.toml";
  options->stream = false;
  CLI::App* cmd = app.add_subcommand(
      "record",
      "Run the board (as `gyrotc run`) and record what a calibration needs: one CSV row per [output]\n"
      "period_s with time_s, sensor_c (casing DS18B20), ambient_c, gyro_mv (raw, mean), the compensated\n"
      "rate, tec_a and the flags. `gyrotc fit --data FILE.csv` reads it (time_s, sensor_c, gyro_mv).\n"
      "Choose what drives the TEC, there is no default: --pid off for a calibration (the TEC stays off\n"
      "while the chamber sweeps the temperature; `gyrotc fit` refuses a record where the loop held it),\n"
      "--pid on to hold the setpoint, --experiment tune for the experiment `gyrotc tune` reads,\n"
      "--experiment selfcal for the sweep `gyrotc calibrate` fits.");
  cmd->add_option("-c,--config", options->config_path, "configuration file (TOML), as for `gyrotc run`")
      ->capture_default_str();
  cmd->add_option("--out", options->record_csv, "CSV file to write")->required();
  cmd->add_option("--duration", options->duration_s, "stop after this many seconds (default: until a signal)")
      ->check(positive_number());
  cmd->add_option("--pid", *pid,
                  "off: TEC off, a free temperature sweep (what a calibration needs); on: hold the setpoint.\n"
                  "Required unless --experiment is given")
      ->check(CLI::IsMember({"on", "off"}));
  auto experiment = std::make_shared<std::string>();
  cmd->add_option("--experiment", *experiment,
                  "tune: run the identification experiment of `gyrotc tune` instead of the PID (rest, full\n"
                  "current to the setpoint, relay, PRBS, coast, cooling, reheat; at most 2 h 35 min, every\n"
                  "fail-safe on) and stop when it ends; then `gyrotc tune --data FILE.csv --out controller.toml`.\n"
                  "selfcal: the self-calibration sweep of `gyrotc calibrate` (which runs it and fits in one step);\n"
                  "then `gyrotc calibrate --data FILE.csv --out calibration.toml`")
      ->check(CLI::IsMember({"tune", "selfcal"}));
  cmd->add_option("--experiment-scale", options->experiment_scale,
                  "--experiment tune on a unit faster than the reference (smaller heat capacities): every phase's\n"
                  "length times this factor (0 < F <= 1; 0.1: at most 16 min). Slow parts of the model (the loss to\n"
                  "the ambient, the shell) are then seen for less long: tune reports wider standard errors for them")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  cmd->add_option("--controller", options->controller_file,
                  "a controller file (`gyrotc tune`'s) in place of the configuration's [control] gains");
  cmd->add_flag("--allow-non-rt", options->allow_non_rt,
                "run without SCHED_FIFO / locked memory when not permitted (a warning)");
  cmd->add_option("--summary-json", options->summary_json, "write the run's summary here");
  cmd->callback([options, pid, experiment, cmd] {
    if (pid->empty() && experiment->empty()) {
      // A usage error (CLI11's, so the hint to --help follows): a default
      // here once made `fit` take a closed-loop record for a calibration.
      throw CLI::ValidationError(
          "record: say what drives the TEC: --pid off (a chamber sweep for `gyrotc fit`), --pid on (hold the "
          "setpoint), --experiment tune or --experiment selfcal");
    }
    if (!pid->empty() && !experiment->empty()) {
      throw CLI::ValidationError("record: --pid and --experiment: choose one (the experiment drives the TEC itself)");
    }
    if (cmd->count("--experiment-scale") > 0 && *experiment != "tune") {
      throw InputError("--experiment-scale: only with --experiment tune");
    }
    if (!pid->empty()) options->pid = *pid == "on";
    options->tune_experiment = *experiment == "tune";
    options->selfcal_experiment = *experiment == "selfcal";
    run_session(*options);
  });
}

}  // namespace gyrotc::app
