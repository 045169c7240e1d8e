#pragma once

#include <cstdint>

#include "gyrotc/algorithms/identify/series_identify.hpp"
#include "gyrotc/algorithms/model/effects.hpp"

// Synthetic chamber records with known hidden effects, to test the
// discrepancy workflow honestly (pure math, deterministic per seed).
//
// The casing follows the chamber (ambient) through a first-order lag with
// the TEC heat; the gyro's bias is a smooth curve through seed Table 2
// evaluated at the casing temperature as seen by model::GyroEffectState (so
// the effects are those of the plant's library); the sensor column is the
// DS18B20 reading (0.0625 C steps); gyro noise is white or AR(1).
namespace gyrotc::identify {

enum class ChamberProfile {
  staircase,       // monotone steps up with holds
  up_down_ramps,   // low -> high -> low at a constant rate, holds at the ends
  random_steps,    // random levels, 1 C/min transitions, random holds
};

enum class NoiseKind { white, ar1 };

struct RecordSpec {
  ChamberProfile profile = ChamberProfile::up_down_ramps;
  double duration_s = 6.0 * 3600.0;
  double sample_period_s = 1.0;
  double low_c = -20.0;
  double high_c = 60.0;
  double ramp_c_per_s = 1.0 / 60.0;  // chamber ramp rate (data/README.md: 1 C/min)
  double casing_tau_s = 300.0;       // chamber -> casing time constant
  double casing_r_th_k_per_w = 5.0;  // casing -> ambient thermal resistance
  double tec_pump_w_per_a = 1.0;     // heat pumped into the casing per ampere
  double tec_step_a = 0.0;           // > 0: random TEC current steps within +/- this
  NoiseKind noise = NoiseKind::white;
  double noise_mv = 0.2;   // standard deviation of the gyro noise
  double ar1_rho = 0.9;    // per sample, for NoiseKind::ar1
  bool quantise_sensor = true;
  model::Effects effects;
  std::uint64_t seed = 1;
};

// Zero-rate output (mV) of seed Table 2 at temp_c: monotone cubic (Fritsch-
// Carlson) interpolation through its 5 C points, linear beyond -40..80 C.
double table2_bias_mv(double temp_c);

SeriesRecord generate_record(const RecordSpec& spec);

}  // namespace gyrotc::identify
