#pragma once

#include <CLI/CLI.hpp>

namespace gyrotc::emu {

// `gyrotc-emu run` (needs libfuse3: CUSE and FUSE).
void add_run_command(CLI::App& app);

}  // namespace gyrotc::emu
