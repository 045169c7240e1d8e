#pragma once

// Whether a time-series record can calibrate the zero-bias model at all,
// before any fit: a fit of a record that cannot calibrate still returns a
// model, and its leave-one-out figure can look excellent (a closed-loop run
// holds one temperature for hours and passes the others in a hurry).
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace gyrotc::fit {

struct RecordSamples {
  std::span<const double> time_s;
  std::span<const double> sensor_c;
  // The board's record has them (setpoint_c, and the flags' TEC-off bit); a
  // chamber logger's own CSV may not: then the hold is not judged.
  std::optional<std::span<const double>> setpoint_c;
  std::optional<std::vector<bool>> tec_on;
};

// The judgement calls, each a number a user can see in the refusal. None of
// them comes from a plant model: they describe a record, not a unit.
struct ScreenLimits {
  double bin_width_c = 1.0;            // as `fit --bin-width` bins the record
  double hold_band_c = 0.5;            // casing this close to the setpoint with the TEC on: held
  double max_held_fraction = 0.5;      // a record mostly held at one setpoint is a closed-loop run
  double rate_window_s = 60.0;         // the casing's rate of change, over this window
  // The die lags the sensor: a bin whose samples moved, on average, faster
  // than this in one direction holds the bias of another temperature. The
  // mean is signed: a bin crossed once up and once down at the same rate
  // (the self-calibration's sweep) sees the lag shift its two halves by
  // equal and opposite amounts, which cancel in its mean.
  double max_rate_c_per_min = 0.5;
  // However balanced, a bin crossed faster than this is not settled (the
  // lag's cancellation holds only while the curve is straight over the lag).
  double max_crossing_rate_c_per_min = 2.0;
  double min_span_c = 20.0;            // a narrower record cannot show the curve's shape
  std::size_t min_bins = 8;            // and the model needs points to be chosen by leave-one-out
  double max_bin_ratio = 10.0;         // fullest bin / median bin: more, and the points' noise differs wildly
};

enum class ScreenCheck { held, span, uneven, unsettled };

struct ScreenFinding {
  ScreenCheck check;
  std::string reason;  // one clause: what the record shows and why it cannot calibrate
};

const char* screen_check_name(ScreenCheck check);  // "held", "span", "uneven", "unsettled"

// The casing's rate of change at each sample, C/min, over +-window/2 (fewer
// at the ends): centred, so a bin's mean rate is that of the samples in it.
std::vector<double> rates_c_per_min(std::span<const double> time_s, std::span<const double> temp_c, double window_s);

// Every check the record fails, in the order of ScreenCheck. `min_bins`
// grows with the model asked for: the caller passes the larger of the
// default and 3 points per coefficient.
std::vector<ScreenFinding> screen_calibration_record(const RecordSamples& record, const ScreenLimits& limits);

}  // namespace gyrotc::fit
