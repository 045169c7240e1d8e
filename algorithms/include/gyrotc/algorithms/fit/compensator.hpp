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

  // Throws std::invalid_argument when the scale factor is not a positive number.
  explicit Compensator(BiasModel model, double scale_mv_per_dps = kSeedScaleMvPerDps);

  // Outside the calibrated range the model is evaluated at the nearest end and
  // temp_clamped is set. A non-finite temperature gives a NaN rate and bias and
  // temp_clamped set: the caller must not output it (the controller keeps the
  // last valid temperature instead).
  Compensated compensate(double gyro_mv, double temp_c) const noexcept;

  const BiasModel& model() const noexcept { return model_; }
  double scale_mv_per_dps() const noexcept { return scale_mv_per_dps_; }

 private:
  BiasModel model_;
  double scale_mv_per_dps_;
};

}  // namespace gyrotc::fit
