#pragma once
// Runs one `gyrotc <command> <args>` in the test process, as main() would
// parse it, and returns what it printed on stdout. Exceptions (InputError,
// CommandExit, ...) propagate after stdout is restored. Defined in
// run_command.cpp, the one test source that compiles CLI11's header.

#include <string>
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace gyrotc::test {

std::string run_command(void (*add_command)(CLI::App&), const std::string& name,
                        const std::vector<std::string>& args);

}  // namespace gyrotc::test
