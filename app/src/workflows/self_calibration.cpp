#include "gyrotc/app/workflows/self_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

namespace {

double median_of(std::vector<double> v) {
  std::erase_if(v, [](double x) { return !std::isfinite(x); });
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

RecordRange read_record_range(const std::string& path, double die_lag_s) {
  const CsvTable table = CsvTable::read(path);
  for (const char* column : {"time_s", "sensor_c"}) {
    if (!table.has(column)) throw InputError(path + ": missing column '" + column + "' (a board record has it)");
  }
  table.require_increasing("time_s");
  const std::vector<double> sensor = calibrate::die_temperature_c(table.numbers("time_s"), table.numbers("sensor_c"),
                                                                  die_lag_s);
  if (sensor.empty()) throw InputError(path + ": no rows");
  RecordRange r;
  r.die_lag_s = std::max(0.0, die_lag_s);
  const auto [lo, hi] = std::minmax_element(sensor.begin(), sensor.end());
  r.low_c = *lo;
  r.high_c = *hi;
  r.ambient_c = table.has("ambient_c") ? median_of(table.numbers_or_nan("ambient_c")) : std::numeric_limits<double>::quiet_NaN();
  r.setpoint_c = table.has("setpoint_c") ? median_of(table.numbers_or_nan("setpoint_c")) : std::numeric_limits<double>::quiet_NaN();
  return r;
}

std::string service_range_gap(const RecordRange& r) {
  char what[96];
  if (r.die_lag_s > 0.0) {
    std::snprintf(what, sizeof what, "the die (the casing sensor through a %.1f s lag)", r.die_lag_s);
  } else {
    std::snprintf(what, sizeof what, "the casing");
  }
  char buf[400];
  if (std::isfinite(r.ambient_c) && r.low_c > r.ambient_c) {
    std::snprintf(buf, sizeof buf,
                  "%s spans %.1f .. %.1f C, above the run's ambient %.1f C: a unit warming from the ambient "
                  "passes temperatures the calibration never saw",
                  what, r.low_c, r.high_c, r.ambient_c);
    return buf;
  }
  if (std::isfinite(r.setpoint_c) && r.high_c < r.setpoint_c) {
    std::snprintf(buf, sizeof buf, "%s spans %.1f .. %.1f C, short of the setpoint %.1f C the unit is held at in service",
                  what, r.low_c, r.high_c, r.setpoint_c);
    return buf;
  }
  return "";
}

SweepLags read_sweep_lags(const std::string& path) {
  const CsvTable table = CsvTable::read(path);
  for (const char* column : {"time_s", "sensor_c", "gyro_mv"}) {
    if (!table.has(column)) throw InputError(path + ": missing column '" + column + "' (a board record has it)");
  }
  table.require_increasing("time_s");
  const std::vector<double> time_s = table.numbers("time_s");
  const std::vector<double> sensor_c = table.numbers_or_nan("sensor_c");
  const std::vector<double> gyro_mv = table.numbers_or_nan("gyro_mv");
  SweepLags lags{calibrate::up_down_difference(time_s, sensor_c, gyro_mv), {}};
  // The record's lag is the fall-back: a search over lags that costs more
  // than the passes' fit, not spent where that measured the lag.
  if (lags.passes.separation.separated) {
    lags.record.why_not = "not read: the up/down passes measure the lag";
  } else {
    lags.record = calibrate::die_lag_from_record(time_s, sensor_c, gyro_mv);
  }
  return lags;
}

}  // namespace gyrotc::app
