#pragma once

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/app/runtime/latency_histogram.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"

// The running daemon as a person and a monitoring system see it: the status
// file under /run/gyrotc that `gyrotc status` reads, the one-sentence STATUS=
// of `systemctl status`, and the Prometheus text file for node_exporter's
// textfile collector. Plain data and its formats; status_publisher.hpp
// builds and writes it once a second.
namespace gyrotc::app {

// The casing is "holding" within this of the setpoint: the seed's accuracy
// (Section 6: maximum absolute error within 0.3 C).
inline constexpr double kHoldingBandC = 0.3;
inline constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();

// A fault flag raised and, once cleared, when.
struct FaultEvent {
  std::string name;  // flag_name()
  double raised_unix_s = 0.0;
  double cleared_unix_s = 0.0;  // 0 while active
};

struct DaemonStatus {
  int pid = 0;
  std::string hal;     // "sim" | "linux"
  std::string config;  // the configuration file
  std::string mode;    // "pid", "tec_off" (compensation only) or "experiment"
  std::string experiment;  // mode "experiment": which ("identification", "self-calibration")
  double started_unix_s = 0.0;
  double written_unix_s = 0.0;
  double uptime_s = 0.0;
  bool running = true;             // false: the daemon has stopped (its last status)
  std::string stopped_by;          // "SIGTERM", "SIGINT", "duration reached", ... when !running
  double casing_c = kNoValue;      // NaN before the first valid reading
  double ambient_c = kNoValue;     // NaN without an ambient sensor
  double setpoint_c = 0.0;         // active (ramped) setpoint
  double held_error_c = kNoValue;  // max |casing - setpoint| since the casing came within kHoldingBandC,
                                   // over 60 s at most (NaN outside the band)
  double tec_a = 0.0;              // commanded TEC current (0 when off)
  double tec_limit_a = 0.0;        // the PID's current limit (the larger of |out_min|, |out_max|)
  double compensation_c = kNoValue;  // the temperature the rate is compensated at (the die's, with a die calibration)
  LoopEstimate estimate;             // the model-based loop's (NaN with the PID)
  std::uint32_t flags = 0;         // controller flags (controller.hpp)
  std::vector<FaultEvent> faults;  // active ones and the last cleared ones, oldest first
  std::string calibration;         // describe(CalibrationInUse)
  std::string calibration_sha256;  // "" for the built-in model
  double calibration_lo_c = kNoValue;       // its range: outside it the rate is compensated at its end
  double calibration_hi_c = kNoValue;
  double calibration_bound_dps = kNoValue;  // its own error bound over the range ([bound]); NaN without one
  LatencyHistogram::Summary latency;
  LoopCounters counters;
};

// The state in one word: "starting" (no casing reading yet), "fault" (a
// flag that stops the TEC or the rate output), "experiment", "tec_off",
// "saturated" (the PID at its limit), "extrapolating" (compensated outside
// the calibration's range: not a fault), "holding" (within kHoldingBandC),
// "warming" / "cooling" (towards the setpoint) or "stopped".
std::string state_word(const DaemonStatus& status);

// One short sentence for STATUS= and the journal, e.g.
// "holding 55.00 °C ±0.03, TEC +0.21 A".
std::string status_sentence(const DaemonStatus& status);

// The status file's JSON (format "gyrotc-status", version 1; docs/GUIDE.md
// lists the fields). NaN figures are null.
std::string status_json(const DaemonStatus& status);

// The latency figures in microseconds, as the status and `run --summary-json` give them:
// count, min, avg, p50, p99, p99_over, max.
nlohmann::json latency_us_json(const LatencyHistogram::Summary& latency);

// The Prometheus text exposition format (version 0.0.4), units in the metric
// names, a HELP and a TYPE line for each.
std::string prometheus_text(const DaemonStatus& status);

// Replaces `path` with `text` atomically (a temporary file in the same
// folder, renamed over it), mode 0644 so that any user's `gyrotc status`
// reads it. Returns "" or why it failed; never throws (the loop's status
// must not stop the daemon).
std::string write_file_atomically(const std::string& path, std::string_view text) noexcept;

}  // namespace gyrotc::app
