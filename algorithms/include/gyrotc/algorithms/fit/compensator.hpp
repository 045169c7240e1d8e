#pragma once

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

struct Compensated {
  double rate_dps;    // (gyro_mv - bias_mv) / scale factor
  double bias_mv;     // the model's zero-rate output at the (clamped) temperature
  bool temp_clamped;  // temperature outside the calibrated range (or not finite)
};

// Per-sample zero-bias compensation (seed Section 5.2): subtract the modelled
// zero-rate output at the measured temperature and divide by the scale factor.
// compensate() does not allocate, lock or throw; it costs one model evaluation.
class Compensator {
 public:
  // Seed Table 2 note: scale factor 8.774 mV/(deg/s).
  static constexpr double kSeedScaleMvPerDps = 8.774;

  // die_lag_s: the model is of the die's temperature, which follows the
  // casing sensor through a first-order lag of this length (a calibration
  // binned by the die, calibrate/die_temperature.hpp); the caller estimates
  // the die's temperature so and passes it as temp_c. 0: the model is of the
  // sensor's reading. Throws std::invalid_argument when the scale factor is
  // not a positive number or the lag is negative or not finite.
  explicit Compensator(BiasModel model, double scale_mv_per_dps = kSeedScaleMvPerDps, double die_lag_s = 0.0);

  // Outside the calibrated range the model is evaluated at the nearest end and
  // temp_clamped is set. A non-finite temperature gives a NaN rate and bias and
  // temp_clamped set: the caller must not output it (the controller keeps the
  // last valid temperature instead).
  Compensated compensate(double gyro_mv, double temp_c) const noexcept;

  const BiasModel& model() const noexcept { return model_; }
  double scale_mv_per_dps() const noexcept { return scale_mv_per_dps_; }
  double die_lag_s() const noexcept { return die_lag_s_; }

 private:
  BiasModel model_;
  double scale_mv_per_dps_;
  double die_lag_s_;
};

}  // namespace gyrotc::fit
