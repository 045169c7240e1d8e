#include <CLI/CLI.hpp>

#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/version.hpp"

namespace gyrotc::app {

void add_gyrotc_commands(CLI::App& cli) {
  cli.description(
      "gyrotc: temperature compensation and control of a MEMS gyroscope\n"
      "(ADS1251 ADC, AD5060 DACs, DS18B20, OPA548-driven TEC; Xia et al., Sensors 2009).");
  cli.set_version_flag("-V,--version", std::string("gyrotc ") + kVersion);
  cli.require_subcommand(1);
  cli.footer("Run 'gyrotc <command> --help' for the options of a command.");
  add_simulate_command(cli);
  add_fit_command(cli);
  add_calibrate_command(cli);
  add_identify_command(cli);
  add_tune_command(cli);
  add_allan_command(cli);
  add_probe_command(cli);
  add_run_command(cli);
  add_record_command(cli);
  add_status_command(cli);
  add_safe_off_command(cli);
  add_check_config_command(cli);
}

}  // namespace gyrotc::app
