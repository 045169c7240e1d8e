#pragma once

#include <CLI/CLI.hpp>

// The `gyrotc-emu` subcommands that need no FUSE: `ctl` (a command to a
// running emulator) and `report` (questions to its event log). `run` lives
// with the FUSE glue (emu/fuse/run_command.cpp).
namespace gyrotc::emu {

inline constexpr const char* kDefaultControlSocket = "/run/gyrotc-emu/control";

void add_ctl_command(CLI::App& app);
void add_report_command(CLI::App& app);

}  // namespace gyrotc::emu
