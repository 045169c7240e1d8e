#pragma once

#include "gyrotc/algorithms/control/housing_model.hpp"
#include "gyrotc/algorithms/model/plant.hpp"

namespace gyrotc::model {

// The plant's own housing as the model-based loop's model (the truth, for
// the loop that knows the plant: issue 72's reference): its network, or the
// default three nodes (shell, casing, die) written as one, and its TEC module.
control::HousingModel housing_model(const PlantParams& plant);

}  // namespace gyrotc::model
