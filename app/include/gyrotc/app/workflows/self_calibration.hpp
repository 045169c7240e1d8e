#pragma once

#include <string>

#include "gyrotc/algorithms/calibrate/die_lag_from_record.hpp"
#include "gyrotc/algorithms/calibrate/up_down_difference.hpp"

// What `gyrotc calibrate` does around the sweep (issue 30): whether a
// record's range covers what the unit will see in service.
namespace gyrotc::app {

struct RecordRange {
  double low_c = 0.0;      // the casing's (sensor_c) span, or the die's estimated from it
  double high_c = 0.0;
  double die_lag_s = 0.0;  // the die's lag behind the sensor the span was estimated with (0: the sensor's)
  double ambient_c = 0.0;   // the median ambient_c (NaN without the column)
  double setpoint_c = 0.0;  // setpoint_c (NaN without the column)
};

// Reads time_s, sensor_c, ambient_c and setpoint_c of a board record; with
// die_lag_s > 0 the span is the die's (calibrate/die_temperature.hpp), which
// the fit bins by. InputError naming the file when a column is missing.
RecordRange read_record_range(const std::string& path, double die_lag_s = 0.0);

// "" when the range covers the ambient of the run up to the setpoint (the
// unit in service warms from one to the other); else why not, one clause.
std::string service_range_gap(const RecordRange& r);

// What a sweep record tells of the die's lag (time_s, sensor_c, gyro_mv;
// InputError naming the file and the column missing): the upward and
// downward passes compared, and, only where they cannot tell the lag from a
// hysteresis, the lag the whole record shows (else record.found is false,
// why_not "not read: ...").
struct SweepLags {
  calibrate::UpDownDifference passes;
  calibrate::RecordLag record;
};
SweepLags read_sweep_lags(const std::string& path);

}  // namespace gyrotc::app
