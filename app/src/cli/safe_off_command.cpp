// `gyrotc safe-off`: only the safe state (systemd ExecStopPost after a crash).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/session.hpp"

namespace gyrotc::app {

void add_safe_off_command(CLI::App& app) {
  auto config_path = std::make_shared<std::string>("/etc/gyrotc/gyrotc.toml");
  CLI::App* cmd = app.add_subcommand(
      "safe-off",
      "Put the TEC stage in the safe state and exit: TEC DAC to 0 A, then the OPA548 disabled, rate DAC\n"
      "mid-scale. For systemd's ExecStopPost, so a crashed or killed daemon never leaves the TEC driving.\n"
      "Opens only those devices: exit 0 once the TEC path is safe, whatever else is missing (a rate DAC\n"
      "that cannot be set is a warning); exit 1 if the TEC path could not be made safe or another gyrotc\n"
      "holds the board.");
  cmd->add_option("-c,--config", *config_path, "configuration file (TOML), as for `gyrotc run`")
      ->capture_default_str();
  cmd->callback([config_path] {
    safe_off_board(load_daemon_config(*config_path));
    std::printf("safe-off: TEC at 0 A, OPA548 disabled (%s)\n", config_path->c_str());
  });
}

}  // namespace gyrotc::app
