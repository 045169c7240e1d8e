#pragma once

#include "gyrotc/algorithms/control/housing_model.hpp"
#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/tune/thermal_identify.hpp"

// The model `gyrotc tune` identifies (thermal_model.hpp) as the model-based
// loop's housing (control/housing_model.hpp), and the loop's design from the
// record alone (issue 72, item 2).
//
// The identified model is written per unit of the casing's heat capacity, so
// the housing is too: the casing's capacity is 1 J/K and every heat is in
// kelvin per second of the casing (the loop's unknown heat included). The
// casing (with the unit's own heat) and the shell, the TEC between them (S = a,
// R = 2 b, K = g), the shell's loss to the ambient e / r, the stage's swing
// from the identified rail (rail_a R), its current limit the smaller of the
// loop's (current_limit_a) and the stage's own (stage_limit_a). The
// identified sensor lag becomes a node of its own (a capacity too small to
// matter) between the casing and the sensor, the node the loop holds: a
// record cannot tell a sensor on a node of its own from a slow sensor, and
// holding the casing would brake the warm-up
// a lag too early. The identified dead time is mostly the age of the reading
// a record row carries, which the loop is told reading by reading; what is
// left becomes the sensor's own lag behind that node.
namespace gyrotc::tune {

control::HousingModel identified_housing(const ThermalModel& m, double current_limit_a);

// The loop's filter and weights from what the fit knows (not from any
// plant): the unknown heat's scale is the larger of the internal heat's
// standard error and that of the heat the TEC gives to hold the setpoint at
// either end of the band (-20 and 35 C); the heat starts with ten times that
// scale and walks by it over the record's length. The readings are the DS18B20's 1/16 C steps with
// the noise the fit found beside them.
control::ObserverLoopSpec identified_observer_spec(const ThermalFit& fit, double setpoint_c, double period_s,
                                                   double design_ambient_c);

}  // namespace gyrotc::tune
