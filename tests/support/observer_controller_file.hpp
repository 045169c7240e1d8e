#pragma once

#include "gyrotc/app/formats/controller_file.hpp"

namespace gyrotc::test {

// A model-based loop's controller file as `tune --loop observer` writes it
// for the nominal plant (tune_suite's nominal record): the identified
// housing, its filter's noises and weights.
inline app::ControllerFile observer_controller_file() {
  app::ControllerFile c;
  c.setpoint_c = 55.0;
  c.period_s = 1.0;
  app::ObserverLoopFile o;
  o.model.peltier_per_a_s = 1.696e-4;
  o.model.joule_k_per_a2_s = 0.01987;
  o.model.loss_per_s = 2.96e-4;
  o.model.shell_ratio = 5.6;
  o.model.shell_tau_s = 75.2;
  o.model.internal_k_per_s = 9.8e-4;
  o.model.dead_time_s = 1.27;
  o.model.sensor_lag_s = 0.0;
  o.model.rail_a = 1.043;
  o.spec.design_ambient_c = 16.0;
  o.spec.reading_noise_c = 0.004;
  o.spec.ambient_noise_c = 0.004;
  o.spec.initial_heat_w = 6.8e-4;
  o.spec.disturbance_w_per_sqrt_s = 8.7e-6;
  c.observer = o;
  c.stuck_min_drive_a = 0.57;
  return c;
}

}  // namespace gyrotc::test
