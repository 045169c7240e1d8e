#pragma once

#include <string>

#include <toml++/toml.h>

#include "gyrotc/app/formats/board_config.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/runtime/realtime_thread.hpp"

// The daemon's configuration file (`gyrotc run`, `record`, `safe-off`): the
// board part (hal, [devices], [tec], [sim]: parse_board_config) plus
//
//   [control]      setpoint_c, kp, ki, kd, period_s, xi_c, out_min_a, out_max_a,
//                  pid, feed_forward_a_per_c, feed_forward_lag_s, setpoint_ramp_c_per_s,
//                  rate_out_v_per_dps, sensor_period_s, controller_file (a
//                  `gyrotc tune` controller file, relative to this file; it
//                  sets setpoint, gains, period, xi, feed-forward, ramp, rail
//                  and stuck drive, which [control] then must not give)
//   [calibration]  file ("" = the seed's reference model)
//   [output]       stream ("stdout" | "file" | "serial" | "none"), path, baud,
//                  period_s, record_csv, record_max_mb, status_interval_s, write_timeout_s,
//                  status_file, metrics_file (relative: to this file's folder)
//   [realtime]     priority, cpu (-1 = any), lock_memory
//   [failsafe]     the FailSafeLimits fields
//
// deploy/config/gyrotc-{sim,linux}.toml document every key. Every error is
// an InputError "<file>:<line>: <section.key>: <why>".
namespace gyrotc::app {

enum class StreamKind { none, stdout_stream, file, serial };

struct OutputConfig {
  StreamKind stream = StreamKind::stdout_stream;
  std::string path;             // file or serial device
  int baud = 115200;            // serial only
  double period_s = 1.0;        // one line / CSV row per period (means over it)
  std::string record_csv;       // "" = no CSV recording
  // The configuration's record_csv is moved to <record_csv>.1 (replacing it) and
  // started again past this size; 0 = no limit. Not for `record --out`.
  double record_max_mb = 100.0;
  double status_interval_s = 10.0;
  double write_timeout_s = 0.05;  // a stalled reader makes lines drop after this
  std::string status_file = "/run/gyrotc/status.json";  // `gyrotc status` reads it; "" = none
  std::string metrics_file;     // Prometheus text file (node_exporter textfile collector); "" = none
};

struct DaemonConfig {
  std::string source;  // the file, for messages
  BoardConfig board;
  ControllerConfig controller;
  double sensor_period_s = 1.0;  // one DS18B20 conversion per period
  std::string calibration_file;  // absolute or relative to the working directory; "" = seed model
  std::string controller_file;   // the controller file in use; "" = [control]
  OutputConfig output;
  RealtimeOptions realtime;
};

DaemonConfig parse_daemon_config(const toml::table& root, const std::string& source);
// Reads and parses path. A relative calibration or controller file is taken
// relative to the configuration file's directory.
DaemonConfig load_daemon_config(const std::string& path);

// The controller of a `gyrotc tune` controller file in place of [control]'s
// (the TEC limits, the rate output and the other fail-safes stay). InputError
// naming the file.
void use_controller_file(DaemonConfig& config, const std::string& path);

}  // namespace gyrotc::app
