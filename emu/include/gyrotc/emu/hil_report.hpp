#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

// What the emulated board's event log (event_log.hpp) says about the daemon
// that drove it: the questions the hardware-in-the-loop checks ask
// (scripts/vm/guest-checks.sh, `gyrotc-emu report`), answered from what the
// hardware saw rather than from what the daemon says of itself.
namespace gyrotc::emu {

struct LogEvent {
  double t_s = 0.0;
  std::string kind, device, value, detail;
};

// The log's events (a last line still being written is left out). Throws
// app::InputError naming the file and line of a malformed one.
std::vector<LogEvent> read_event_log(const std::string& path);
// The time of the last "mark" event whose text is `text`; none if absent.
std::optional<double> mark_time(const std::vector<LogEvent>& events, const std::string& text);

// Did the true casing temperature (the plant's, not the sensor's) stay
// within band_c of setpoint_c for hold_s, from some time after after_s on?
struct SettleResult {
  bool settled = false;
  double settled_at_s = 0.0;      // the start of the first such stretch
  double max_abs_error_c = 0.0;   // over that stretch (or over the longest one)
  double longest_hold_s = 0.0;    // the longest stretch inside the band
  double last_error_c = 0.0;
  std::size_t samples = 0;
};
SettleResult find_settle(const std::vector<LogEvent>& events, double setpoint_c, double band_c, double hold_s,
                         double after_s);

// The daemon's record (time_s from its start, the compensated rate, flags)
// against the rate-DAC codes the hardware latched: the record's start is
// found by matching each row's mean with the mean of the codes in its
// period, and rows flagged ADC-invalid are left out.
struct RecordRow {
  double time_s = 0.0;
  double rate_dps = 0.0;  // NaN: no valid sample in the period
  unsigned flags = 0;
};
// Reads time_s, rate_dps_compensated and flags of a gyrotc record CSV.
std::vector<RecordRow> read_record(const std::string& path);

struct DacScale {
  double vref_v = 2.5;           // the rate DAC's reference
  double v_per_dps = 0.01;       // [control] rate_out_v_per_dps: mid-scale is 0 deg/s
  double lsb_dps() const { return vref_v / 65536.0 / v_per_dps; }
  double rate_of(unsigned code) const { return (code * vref_v / 65536.0 - 0.5 * vref_v) / v_per_dps; }
};
struct CompensationResult {
  std::size_t rows = 0;           // rows compared
  std::size_t frames = 0;         // DAC frames in them
  double start_s = 0.0;           // the record's time 0 on the log's clock
  double max_diff_lsb = 0.0;      // the worst |mean of the codes - the row|, in rate-DAC LSBs
  double worst_row_time_s = 0.0;
  double mean_rate_dps = 0.0;     // the mean of the codes latched in the mean's window, as a rate
  std::size_t mean_frames = 0;
  double lsb_dps = 0.0;
};
// after_s/until_s bound the log's frames: the daemon's run, from before its
// start (the record's time 0 is looked for near the first frame); rows whose
// period is not inside them are left out. The mean is taken over the frames
// in [mean_from_s, until_s]. Throws app::InputError when nothing matches.
CompensationResult compare_compensation(const std::vector<LogEvent>& events, const std::vector<RecordRow>& rows,
                                        const DacScale& scale, double after_s, double until_s, double mean_from_s);

// When, after after_s, the TEC path was safe (the TEC DAC at the 0 A code and
// E/S low, both), and when after that the TEC drove again (E/S high with the
// DAC off the 0 A code).
struct SafeResult {
  std::optional<double> tec_zero_s;  // the DAC at the 0 A code (already there: after_s)
  int tec_zero_pid = 0;              // the process that wrote it there after after_s (0: written before)
  std::optional<double> es_low_s;
  std::optional<double> safe_s;      // both
  std::optional<double> resumed_s;
  // E/S alone: a TEC DAC that refuses every frame (an SPI error) keeps its last
  // code, and the disabled OPA548 is what makes the path safe.
  std::optional<double> es_resumed_s;  // E/S high again after es_low_s, the DAC off the 0 A code
};
SafeResult find_safe(const std::vector<LogEvent>& events, unsigned zero_code, double after_s);

}  // namespace gyrotc::emu
