#pragma once

#include <CLI/CLI.hpp>

// Every `gyrotc <command>` registers itself through one of these; main()
// calls them in the order they appear in --help. Each command's callback
// throws InputError / RuntimeFailure for main() to report.
namespace gyrotc::app {

}  // namespace gyrotc::app
