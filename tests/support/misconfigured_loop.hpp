#pragma once

#include <memory>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/app/runtime/controller.hpp"

namespace gyrotc::test {

// A controller whose model-based loop drives the wrong way for its first
// minute: designed on the default housing, but its model reads the ambient
// sensor `ambient_offset_c` off (an offset entered with the wrong sign), so
// it holds against a room at design_ambient_c where the readings say
// otherwise; its filter is told the housing has no unknown heat to learn,
// its LQ weights are soft (a loop configured by hand, badly). The runaway
// check (FailSafeLimits::runaway_s, runaway_c) is set to look at that
// minute's first 20 s, where the reading moves 0.5 C.
inline app::ControllerConfig misconfigured_loop_config(double ambient_offset_c, double design_ambient_c,
                                                       double period_s = 1.0) {
  app::ControllerConfig config;
  control::HousingModel model = model::housing_model(model::PlantParams{});
  model.network.ambient_sensor.offset_c = ambient_offset_c;
  control::ObserverLoopSpec spec;
  spec.setpoint_c = config.setpoint_c;
  spec.period_s = period_s;
  spec.design_ambient_c = design_ambient_c;
  spec.disturbance_w_per_sqrt_s = 1e-7;
  spec.initial_heat_w = 1e-4;
  spec.error_scale_c = 2.0;
  config.observer = std::make_shared<const control::ObserverLoopDesign>(control::design_observer_loop(model, spec));
  config.pid.period_s = period_s;
  config.limits.runaway_s = 20.0;
  config.limits.runaway_c = 0.5;
  return config;
}

}  // namespace gyrotc::test
