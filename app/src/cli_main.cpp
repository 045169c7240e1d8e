#include "gyrotc/app/cli_main.hpp"

#include <cstdio>
#include <exception>

#include "gyrotc/app/errors.hpp"

namespace gyrotc::app {

int run_cli(CLI::App& cli, int argc, char** argv, const char* program) {
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e);
  } catch (const CommandExit& e) {
    return e.status();
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 1;
  }
  return 0;
}

}  // namespace gyrotc::app
