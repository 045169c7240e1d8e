// `gyrotc run`: the controller daemon (issue 6).
#include <CLI/CLI.hpp>

#include <memory>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/session.hpp"

namespace gyrotc::app {

void add_run_command(CLI::App& app) {
  auto options = std::make_shared<SessionOptions>();
  options->config_path = "/etc/gyrotc/gyrotc.toml";
  CLI::App* cmd = app.add_subcommand(
      "run",
      "The controller daemon: compensates every gyro sample in a SCHED_FIFO loop paced by the ADC's DRDY\n"
      "(or, with hal = \"sim\", by the simulated board in real time), runs the PID on the TEC every period,\n"
      "streams and records the data. SIGINT/SIGTERM: TEC 0 A, OPA548 disabled, outputs flushed, exit 0;\n"
      "SIGHUP (systemctl reload): re-read the configuration; the calibration, the controller and the outputs\n"
      "change without stopping the loop, other changed keys are named as taking a restart.");
  cmd->add_option("-c,--config", options->config_path,
                  "configuration file (TOML): hal, [devices], [tec], [sim], [control], [calibration], [output], "
                  "[realtime], [failsafe]; see deploy/config/")
      ->capture_default_str();
  cmd->add_option("--duration", options->duration_s, "stop after this many seconds (default: until a signal)")
      ->check(positive_number());
  cmd->add_option("--controller", options->controller_file,
                  "a controller file (`gyrotc tune`'s) in place of the configuration's [control] gains");
  cmd->add_flag("--allow-non-rt", options->allow_non_rt,
                "run without SCHED_FIFO / locked memory when not permitted (a warning; samples may be late)");
  cmd->add_option("--summary-json", options->summary_json,
                  "write the run's summary here (JSON: samples, overruns, missed_conversions, late_reads, "
                  "spurious_edges, adc_timeouts, latency_us min/avg/p50/p99/max; with hal = \"sim\" also sim_adc, "
                  "what the simulated ADS1251 saw)");
  cmd->callback([options] { run_session(*options); });
}

}  // namespace gyrotc::app
