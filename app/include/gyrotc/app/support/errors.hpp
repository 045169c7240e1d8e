#pragma once

#include <stdexcept>
#include <string>

namespace gyrotc::app {

// Bad input from the user (CLI arguments, CSV, TOML): the message already
// names the file, line or key. main() prints it as one line and exits 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A failure at run time that is not the user's input (a device, a full disk).
// main() prints it as one line and exits 1.
class RuntimeFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A command that has already reported what happened and wants main() to exit
// with this status (e.g. `gyrotc probe` when a device failed).
class CommandExit : public std::exception {
 public:
  explicit CommandExit(int status) : status_(status) {}
  int status() const noexcept { return status_; }
  const char* what() const noexcept override { return "command exit"; }

 private:
  int status_;
};

}  // namespace gyrotc::app
