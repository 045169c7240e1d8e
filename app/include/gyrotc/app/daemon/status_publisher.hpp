#pragma once

#include <deque>
#include <string>
#include <utility>

#include "gyrotc/app/daemon/daemon_status.hpp"
#include "gyrotc/app/formats/calibration_in_use.hpp"

namespace gyrotc::app {

struct StatusPublisherOptions {
  std::string status_file;   // "" = none ([output] status_file)
  std::string metrics_file;  // "" = none ([output] metrics_file)
  DaemonStatus identity;     // pid, hal, config, mode, calibration, tec_limit_a, started_unix_s
};

// Turns the runner's state into the DaemonStatus once a second (the daemon's
// main thread calls update()): keeps the 60 s error window and the fault
// history, writes the status and metrics files atomically, and logs the
// state when it changes (a new state must last 3 updates first, so a loop at
// the edge of the holding band does not fill the journal). A file that
// cannot be written is a warning once, never a stop.
// The calibration's fields of a status: describe(), sha256, range and bound.
void set_status_calibration(DaemonStatus& status, const CalibrationInUse& calibration);

class StatusPublisher {
 public:
  explicit StatusPublisher(StatusPublisherOptions options);

  // The sentence for STATUS=.
  std::string update(const LoopStatus& loop, const LoopCounters& counters, const LatencyHistogram::Summary& latency,
                     double uptime_s, double now_unix_s);
  // After a reload: the calibration in use (its description, range and bound).
  void set_calibration(const CalibrationInUse& calibration);
  // After a reload: the files to write from now on. A file no longer named is
  // removed (it would read as a daemon that died).
  void set_files(const std::string& status_file, const std::string& metrics_file);
  // After a reload: "pid" or "tec_off", and the PID's current limit.
  void set_control(std::string mode, double tec_limit_a);
  // The last status: running = false, the TEC at 0 A; the status file stays
  // for `gyrotc status` to tell how the daemon ended.
  void stopped(const std::string& stopped_by, const LoopCounters& counters, const LatencyHistogram::Summary& latency,
               double uptime_s, double now_unix_s);
  const DaemonStatus& status() const noexcept { return status_; }

 private:
  void track_faults(std::uint32_t flags, double now_unix_s);
  void write();
  void write_one(const std::string& path, const std::string& text, const char* key, bool& warned);

  StatusPublisherOptions options_;
  DaemonStatus status_;
  std::deque<std::pair<double, double>> errors_;  // (uptime_s, |casing - setpoint|) in the band, last 60 s
  std::string logged_state_;
  std::string candidate_state_;
  int candidate_count_ = 0;
  bool status_warned_ = false;
  bool metrics_warned_ = false;
};

}  // namespace gyrotc::app
