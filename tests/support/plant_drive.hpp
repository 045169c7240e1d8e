#pragma once

#include "gyrotc/algorithms/model/plant.hpp"

namespace gyrotc::test {

// The TEC drive DAC's voltage that commands current_a on the plant's stage
// (mid-scale is 0 A).
inline double drive_v_for(const model::PlantParams& p, double current_a) {
  return 0.5 * p.dac_vref_v + current_a / p.gain_a_per_v;
}

}  // namespace gyrotc::test
