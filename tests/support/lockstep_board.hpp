#pragma once

#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/hal/sim/sim_board.hpp"

namespace gyrotc::test {

// A plant starting at the room's temperature.
inline model::PlantParams plant_at(model::PlantParams p, double ambient_c) {
  p.initial_temp_c = ambient_c;
  return p;
}

// A lockstep simulated board for the thermal loop's tests: the plant's own
// integration step and current limit, the ADC at 20 samples a second (the
// thermal loop is the subject, not the ADC).
inline hal::SimBoardOptions lockstep_board_options(const model::PlantParams& p) {
  hal::SimBoardOptions o;
  o.realtime = false;
  o.thermal_step_s = p.max_thermal_step_s;
  o.adc.fclk_hz = 20.0 * 384.0;
  o.tec_current_limit_a = p.current_limit_a;
  return o;
}

}  // namespace gyrotc::test
