#pragma once
// Reading the status file a running daemon rewrites once a second
// (StatusPublisher): `gyrotc status` shows it, `gyrotc calibrate --install`
// finds the daemon to reload from it.
#include <nlohmann/json.hpp>
#include <string>

namespace gyrotc::app {

struct DaemonStatusRead {
  nlohmann::json status;        // the file's fields
  int pid = 0;
  double written_unix_s = 0.0;
  double age_s = 0.0;
  // "" while the daemon runs; else one sentence: stopped (when, by what),
  // gone without stopping, or silent for longer than max_age_s.
  std::string problem;
};

// RuntimeFailure when there is no status file (naming it) or it is not one.
DaemonStatusRead read_daemon_status(const std::string& path, double max_age_s);

// How the status's times read for a person: local "YYYY-MM-DD HH:MM:SS",
// and a duration as "42 s", "12 min 05 s" or "3 h 20 min".
std::string clock_time(double unix_s);
std::string duration_text(double s);

}  // namespace gyrotc::app
