#pragma once

#include <optional>
#include <string>

#include "gyrotc/app/daemon/config.hpp"

// What `gyrotc run`, `gyrotc record` and `gyrotc safe-off` do, behind their
// command lines.
namespace gyrotc::app {

struct SessionOptions {
  std::string config_path;
  double duration_s = 0.0;        // 0: until SIGINT / SIGTERM
  bool allow_non_rt = false;      // run without SCHED_FIFO / mlockall, warning
  std::string summary_json;       // "" = none
  std::optional<bool> pid;        // overrides [control] pid
  std::string record_csv;         // overrides [output] record_csv
  bool stream = true;             // false: no line stream ([output] stream ignored)
  std::string controller_file;    // a `gyrotc tune` controller file in place of [control]'s
  // The identification experiment of `gyrotc tune` (tune/experiment.hpp) in
  // the PID's place; the run ends when it does (or at duration_s / a signal).
  bool tune_experiment = false;
  double experiment_scale = 1.0;  // tune::ExperimentPlan::scaled: for units faster than the reference
  // The self-calibration sweep of `gyrotc calibrate` (calibrate/sweep_experiment.hpp),
  // likewise; at most one of the two.
  bool selfcal_experiment = false;
};

// Runs the real-time runner on the configured board until the duration ends,
// an experiment ends, or SIGINT/SIGTERM (SIGHUP reloads what config_reload.hpp says), then puts the
// board in the safe state, prints the summary and returns (exit 0). Throws
// InputError / RuntimeFailure, the board safe-off done.
// Returns how the run stopped: "SIGINT", "SIGTERM", "experiment finished" or
// "duration reached".
std::string run_session(const SessionOptions& options);

// The TEC DAC to 0 A and the OPA548 disabled on the configured board, the
// rate DAC to mid-scale if it can be (a warning if not). Only those devices
// are opened: a missing sensor or ADC does not matter. Throws RuntimeFailure
// unless the TEC path was made safe (or when another gyrotc holds the board).
void safe_off_board(const DaemonConfig& config);

}  // namespace gyrotc::app
