#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"

// Designs the temperature loop for an identified ThermalModel (issue 23): the
// seed's integral-separated incremental PID (Eq. 17/18) with the gains, the
// separation band xi and the feed-forward chosen for this unit, the stage's
// rail limit for the anti-windup, and the stuck-sensor drive threshold above
// the unit's holding current.
//
// Robustness margin: on the model linearised at the setpoint the loop's
// maximum sensitivity Ms = max |1 / (1 + L)| must stay <= max_sensitivity
// (1.6: gain margin >= 2.7, phase margin >= 36 deg), and <= max_sensitivity
// _perturbed for the TEC gain x0.5 and x2, every rate x0.5 and x2 (the heat
// capacity halved or doubled) and 4 s more dead time. Among the gains that
// pass, the design simulates the closed loop on the identified model (the
// Controller's law through control/tec_law.hpp, DS18B20 steps and timing):
// a warm-up at the room temperature of the record, then the chamber going
// to rated_low_c and rated_high_c at 1 C/min with 20 min holds. It keeps the
// gains with the smallest error while the ambient is within the band, and
// among those within 3 mC of it the fastest settling; then the separation
// band with the fastest settling. The feed-forward's slope is searched with
// the gains: the line through zero that best matches the holding current over
// the band, or the holding current's own slope there. Ambients at which the
// unit cannot hold the setpoint at all (its current limits and rails) are left
// out of the programme and the band: no gains help there.
namespace gyrotc::tune {

struct DesignSpec {
  double setpoint_c = 55.0;             // seed Section 6
  double period_s = 2.0;                // seed Section 6.1: T = 2 s
  double sensor_period_s = 1.0;         // one DS18B20 conversion per second
  double sensor_step_c = 0.0625;        // DS18B20 12-bit resolution
  double ambient_period_s = 10.0;       // the ambient converts before every 10th casing reading
  bool ambient_sensor = true;           // feed-forward from an ambient reading
  double min_a = -1.0;                  // the TEC current limits
  double max_a = 1.0;
  bool rail_known = false;              // the identified rail limits the stage
  bool shell_known = true;              // the record pins the shell down: the feed-forward's lag
  double room_c = 16.0;                 // the warm-up's ambient
  double band_low_c = -20.0;            // seed Section 6.2: hold while the ambient is within
  double band_high_c = 35.0;
  double rated_low_c = -30.0;           // the chamber goes this far (seed Fig. 26)
  double rated_high_c = 45.0;
  double chamber_ramp_c_per_s = 1.0 / 60.0;  // data/README.md: 1 C/min
  double hold_s = 1200.0;               // 20 min holds
  double settle_band_c = 0.3;           // settling: |error| <= 0.3 C for 300 s (issue 4)
  double settle_hold_s = 300.0;
  double max_sensitivity = 1.6;
  double max_sensitivity_perturbed = 2.5;
};

struct LoopMargins {
  double max_sensitivity = 0.0;
  double gain_margin = 0.0;        // factor (inf when the phase never reaches -180 deg)
  double phase_margin_deg = 0.0;
  double crossover_rad_s = 0.0;
};

struct PidGains {
  double kp = 0.0;  // seed gain form: KI = Kp T/TI, KD = Kp TD/T
  double ki = 0.0;
  double kd = 0.0;
  double xi_c = 0.0;
};

struct PerturbedMargin {
  std::string perturbation;
  double max_sensitivity = 0.0;
};

struct LoopRun {
  double settle_s = -1.0;              // < 0: never settled
  double max_error_in_band_c = 0.0;    // after settle + hold, ambient within the band
  double max_error_c = 0.0;            // after settle + hold, any ambient
};

struct ControllerDesign {
  PidGains gains;
  double feed_forward_a_per_c = 0.0;
  double feed_forward_lag_s = 0.0;     // the ambient through the model's shell (control::AmbientLag)
  double setpoint_ramp_c_per_s = 0.0;  // a step: nothing the unit can follow is faster
  control::RailLimit rail;
  double stuck_min_drive_a = 0.5;

  LoopMargins margins;                 // identified model, at the setpoint, room ambient
  std::vector<PerturbedMargin> perturbed;
  LoopRun predicted;                   // the design programme on the identified model
  double minimum_settle_s = -1.0;      // full heating from power-on at room_c into the settle band
  // Steady current that holds the setpoint (NaN: the unit cannot), over the rated range.
  std::vector<double> holding_ambient_c;
  std::vector<double> holding_a;
  std::size_t candidates = 0;          // gain sets tried
  std::size_t robust_candidates = 0;   // ... that passed the margins
};

// Throws std::invalid_argument when the model cannot hold the setpoint at the
// room temperature within the current limits (nothing to design for).
ControllerDesign design_controller(const ThermalModel& model, const DesignSpec& spec);

// The stuck-sensor check's drive threshold (ControllerDesign::stuck_min_drive_a),
// whatever loop holds the unit: above any steady holding current over the
// rated ambients, at least 0.5 A, at most the current limit.
double stuck_min_drive_a(const ThermalModel& model, const DesignSpec& spec);

LoopMargins loop_margins(const ThermalModel& model, const DesignSpec& spec, const PidGains& gains, double ambient_c);

// The design programme (warm-up at room_c, then the chamber's excursions) on
// the model in closed loop with the Controller's law.
LoopRun simulate_loop(const ThermalModel& model, const DesignSpec& spec, const PidGains& gains,
                      double feed_forward_a_per_c, double feed_forward_lag_s, const control::RailLimit& rail);

// The model's physical minimum: from power-on at room_c (every node at
// room_c) at full heating current
// into the settle band (s); < 0 when it never gets there within 3 h.
double minimum_settle_s(const ThermalModel& model, const DesignSpec& spec);

}  // namespace gyrotc::tune
