#pragma once

#include <CLI/CLI.hpp>

// The end of every gyrotc executable's main(): parses the command line and
// runs the subcommand, turning what it throws into the exit status and one
// line on stderr ("<program>: error: ..."): a usage error as CLI11 reports
// it, InputError 2, any other failure 1, CommandExit its own status.
namespace gyrotc::app {

int run_cli(CLI::App& cli, int argc, char** argv, const char* program);

}  // namespace gyrotc::app
