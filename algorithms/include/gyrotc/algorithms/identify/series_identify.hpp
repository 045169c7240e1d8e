#pragma once

#include <functional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/identification.hpp"

// The workflow on time series (what `gyrotc record` / `simulate --out`
// write): gyro_mv against the DS18B20 reading, or sensor_c against the
// chamber and the TEC drive.
//
// gyro_mv baseline: the bias is a flexible function of the sensor
// temperature (cubic B-spline, one interval per 2 C), calibrated to the
// record, so that only what a curve in T cannot absorb is left; the noise is
// white plus a slow Gauss-Markov wander of the bias (wander_noise.hpp).
// Candidates: thermal_lag, rate_sensitivity, ramp_hysteresis,
// ambient_sensitivity, warm_up, linear_drift (model/effects.hpp; linear_drift
// only on records without gaps, across which it cannot be told from the
// bias wander; the note says so). T is the
// sensor reading smoothed over `smooth_s` (centred, no lag) and dT/dt its
// centred difference (a rate sensitivity's and a ramp hysteresis' over
// `effect_rate_s`).
//
// sensor_c baseline: one-node RC casing, T = a*L[ambient] + g*L[tec_a] +
// c + e*exp(-t/tau) with L the unit-gain first-order lag of time constant
// tau (fitted). Candidate: tec_joule_heating (+ k*L[tec_a^2]; r_ohm = 2 k /
// r_th, with r_th the casing-to-ambient thermal resistance given).
//
// The record is averaged into at most max_bins equal time bins before
// fitting (thermal effects are slow); cost is linear in the record length.
// Samples may come at any spacing. A step longer than gap_s is a gap: the
// temperatures are interpolated across it (so the lags run on), its bins are
// not fitted, nor those within settle_s after it.
namespace gyrotc::identify {

struct SeriesRecord {
  std::vector<double> time_s;
  std::vector<double> ambient_c;
  std::vector<double> sensor_c;
  std::vector<double> gyro_mv;
  std::vector<double> tec_a;  // may be empty (gyro_mv target)
};

struct SeriesOptions {
  double smooth_s = 60.0;
  // The dT/dt a rate sensitivity and a ramp hysteresis follow: the
  // difference of two means over this window, this far apart (the probes',
  // the regions' and the identifiability rules' dT/dt: over smooth_s).
  // Longer, because these effects act through the rate itself: on a casing
  // approaching a hold, or ramping slowly, the reading steps by 0.0625 C once
  // in minutes, and over 60 s its slope flickers between 0 and a step per
  // window (0.001 C/s), noise in the regressor that the effect's amplitude
  // multiplies and the wander then takes in its place (docs/IDENTIFY.md,
  // runs 10 and 11).
  double effect_rate_s = 120.0;
  std::size_t max_bins = 3000;
  int folds = 5;
  double cv_block_s = 300.0;
  // sensor_c target: the casing-to-ambient thermal resistance, K/W, that turns
  // the fitted Joule term (the casing's rise per A^2) into the TEC's r_ohm.
  // A record cannot tell it apart from r_ohm: 0 = not known, and then only
  // rise_k_per_a2 is given.
  double casing_r_th_k_per_w = 0.0;
  // gyro_mv: the base model's own lag from the sensed casing to the die
  // (the plant's die capacity / casing-die conductance); 0 takes the sensor
  // temperature as the die's. Effects then act on top of it, as in the plant.
  double base_die_tau_s = 0.0;
  double gap_s = 60.0;
  double settle_s = 600.0;
};

enum class SeriesTarget { gyro_mv, sensor_c };

// Throws std::invalid_argument (a one-line reason) for records that are too
// short, not increasing in time, lack the columns the target needs, are
// sampled too coarsely for dT/dt (fewer than 3 samples per smooth_s), are
// mostly gaps (less than half the span or fewer than 200 bins left to fit),
// or (sensor_c) have a gap longer than settle_s, across which the casing
// model cannot carry its state.
Identification identify_series(const SeriesRecord& record, SeriesTarget target,
                               const SeriesOptions& options = {}, const Criteria& criteria = {},
                               const std::function<void(double)>& progress = {});

}  // namespace gyrotc::identify
