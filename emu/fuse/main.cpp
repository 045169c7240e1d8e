// gyrotc-emu: the board emulator (docs/EMULATOR.md).
#include <CLI/CLI.hpp>

#include <string>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/version.hpp"
#include "gyrotc/emu/emu_commands.hpp"
#include "run_command.hpp"

int main(int argc, char** argv) {
  CLI::App cli{
      "gyrotc-emu: the simulated gyrotc board behind the kernel's own interfaces\n"
      "(CUSE spidev nodes, a gpio-sim chip, a w1_therm tree), so that the unmodified daemon with hal = \"linux\"\n"
      "can be run and checked end to end without the board: bring-up of a new configuration, and\n"
      "hardware-in-the-loop tests."};
  cli.set_version_flag("-V,--version", std::string("gyrotc-emu ") + gyrotc::app::kVersion);
  cli.require_subcommand(1);
  cli.footer("Run 'gyrotc-emu <command> --help' for the options of a command.");
  gyrotc::emu::add_run_command(cli);
  gyrotc::emu::add_ctl_command(cli);
  gyrotc::emu::add_report_command(cli);
  return gyrotc::app::run_cli(cli, argc, argv, "gyrotc-emu");
}
