#pragma once

#include <iostream>
#include <ostream>

// Declared, not included (commands.hpp says why).
namespace CLI {
class App;
class Validator;
}  // namespace CLI

// The end of every gyrotc executable's main(): parses the command line and
// runs the subcommand, turning what it throws into the exit status and one
// line on `err` ("<program>: error: ..."):
//  - no arguments: a short help (one line per command) on `out`, status 0;
//  - --help, --version: as CLI11 prints them, status 0;
//  - a usage error (unknown command or option, a bad or missing value): the
//    error, a "did you mean" for a misspelt command or option, and where the
//    help is, status 2;
//  - InputError (bad input file or value) 2, any other failure 1, CommandExit
//    its own status.
// Unsigned options refuse a sign ("--seed -1" would otherwise wrap).
namespace gyrotc::app {

int run_cli(CLI::App& cli, int argc, const char* const* argv, const char* program, std::ostream& out = std::cout,
            std::ostream& err = std::cerr);

// A number > 0 (CLI11's PositiveNumber prints its limit, DBL_MAX, in all its 309 digits).
CLI::Validator positive_number();

}  // namespace gyrotc::app
