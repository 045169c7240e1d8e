#pragma once
// The gyro die's temperature, estimated from the casing sensor's record (issue
// 30). The die sits inside the casing behind a thermal resistance: it follows
// the sensor through a first-order lag, dT_die/dt = (T_sensor - T_die) / lag.
// The zero-rate output is a function of the die's temperature, so a sweep's
// record binned by the estimated die temperature puts each sample's bias where
// it belongs: the up/down cancellation of a sweep (docs/SELFCAL.md) leaves
// f''(T) (lag rate)^2 / 2 in each bin and the ends, where the die never
// reached the casing's extreme, wrong; binning by the die leaves neither.
#include <span>
#include <vector>

namespace gyrotc::calibrate {

// The sensor's readings through a first-order lag of lag_s, the sensor taken
// as moving linearly between readings (exact for a ramp). The die starts at
// the first finite reading (a unit that has sat at the ambient). A row
// without a finite reading gets NaN and the lag carries on over the gap from
// the last reading. lag_s <= 0: the readings themselves.
// Throws std::invalid_argument when the spans differ in length, the times
// decrease or lag_s is not finite.
std::vector<double> die_temperature_c(std::span<const double> time_s, std::span<const double> sensor_c,
                                      double lag_s);

}  // namespace gyrotc::calibrate
