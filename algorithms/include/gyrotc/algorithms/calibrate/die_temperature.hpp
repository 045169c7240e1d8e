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

// The same estimate, one reading at a time: what the Controller compensates
// at on the board, so that a model fitted against the die's temperature is
// evaluated at the die's temperature in service too. update() does not
// allocate or throw.
class DieTemperature {
 public:
  // A reading taken at time_s (not before the last one; an earlier time is
  // taken as the last one's). The first reading starts the die at it; each
  // later one moves the die as if the sensor went linearly from the last
  // reading to this one. lag_s <= 0 (or not finite): the die is the reading.
  void update(double time_s, double sensor_c, double lag_s) noexcept;
  bool started() const noexcept { return started_; }
  double die_c() const noexcept { return die_c_; }  // meaningful once started()

 private:
  bool started_ = false;
  double last_time_s_ = 0.0;
  double last_sensor_c_ = 0.0;
  double die_c_ = 0.0;
};

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
