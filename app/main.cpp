#include <CLI/CLI.hpp>

#include <string>

#include "gyrotc/app/cli_main.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/version.hpp"

int main(int argc, char** argv) {
  CLI::App cli{
      "gyrotc: temperature compensation and control of a MEMS gyroscope\n"
      "(ADS1251 ADC, AD5060 DACs, DS18B20, OPA548-driven TEC; Xia et al., Sensors 2009)."};
  cli.set_version_flag("-V,--version", std::string("gyrotc ") + gyrotc::app::kVersion);
  cli.require_subcommand(1);
  cli.footer("Run 'gyrotc <command> --help' for the options of a command.");
  gyrotc::app::add_identify_command(cli);
  gyrotc::app::add_probe_command(cli);
  gyrotc::app::add_fit_command(cli);
  gyrotc::app::add_simulate_command(cli);
  gyrotc::app::add_tune_command(cli);
  gyrotc::app::add_allan_command(cli);
  gyrotc::app::add_run_command(cli);
  gyrotc::app::add_record_command(cli);
  gyrotc::app::add_safe_off_command(cli);

  return gyrotc::app::run_cli(cli, argc, argv, "gyrotc");
}
