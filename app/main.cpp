#include <CLI/CLI.hpp>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"

int main(int argc, char** argv) {
  CLI::App cli;
  gyrotc::app::add_gyrotc_commands(cli);
  return gyrotc::app::run_cli(cli, argc, argv, "gyrotc");
}
