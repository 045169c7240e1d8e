#include "gyrotc/algorithms/identify/record_generator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

namespace gyrotc::identify {
namespace {

// Seed Table 2: uncompensated zero-rate output (mV), -40..80 C in 5 C steps.
constexpr std::array<double, 25> kTable2Mv = {98.1, 105.9, 107.5, 108.2, 109.1, 108.9, 105.7,
                                              103.5, 102.7, 98.4,  94.2,  88.3,  85.8,  79.9,
                                              74.4,  68.4,  60.6,  54.5,  51.6,  50.3,  52.4,
                                              53.5,  53.2,  52.2,  52.7};
constexpr double kTable2FirstC = -40.0;
constexpr double kTable2StepC = 5.0;
constexpr double kDs18b20StepC = 0.0625;  // DS18B20 12-bit resolution

// Fritsch-Carlson slopes of the Table 2 points (mV/C).
std::array<double, 25> table2_slopes() {
  std::array<double, 24> d{};
  for (std::size_t i = 0; i + 1 < kTable2Mv.size(); ++i) d[i] = (kTable2Mv[i + 1] - kTable2Mv[i]) / kTable2StepC;
  std::array<double, 25> m{};
  m[0] = d[0];
  m[24] = d[23];
  for (std::size_t i = 1; i < 24; ++i) {
    m[i] = d[i - 1] * d[i] <= 0.0 ? 0.0 : 2.0 / (1.0 / d[i - 1] + 1.0 / d[i]);
  }
  return m;
}

// Chamber (ambient) programme as breakpoints (time, level), linear between.
struct Programme {
  std::vector<double> t, level;
  double at(double time) const {
    if (time <= t.front()) return level.front();
    if (time >= t.back()) return level.back();
    const auto it = std::upper_bound(t.begin(), t.end(), time);
    const auto i = static_cast<std::size_t>(it - t.begin());
    const double f = (time - t[i - 1]) / (t[i] - t[i - 1]);
    return level[i - 1] + f * (level[i] - level[i - 1]);
  }
  void go(double to, double rate, double hold) {
    const double dt = std::fabs(to - level.back()) / rate;
    t.push_back(t.back() + std::max(dt, 1.0));
    level.push_back(to);
    t.push_back(t.back() + hold);
    level.push_back(to);
  }
};

Programme programme(const RecordSpec& s, std::mt19937_64& rng) {
  Programme p{{0.0}, {s.low_c}};
  const double span = s.high_c - s.low_c;
  switch (s.profile) {
    case ChamberProfile::staircase: {
      constexpr int kSteps = 6;
      const double hold = s.duration_s / (kSteps + 1);
      p.t.push_back(hold);
      p.level.push_back(s.low_c);
      for (int k = 1; k <= kSteps; ++k) p.go(s.low_c + span * k / kSteps, 10.0 * s.ramp_c_per_s, hold);
      break;
    }
    case ChamberProfile::up_down_ramps: {
      // Ramps at the given rate, the rest of the time split into holds.
      double ramp_time = span / s.ramp_c_per_s;
      int cycles = std::max(1, static_cast<int>(s.duration_s / (2.5 * ramp_time)));
      const double hold = std::max(60.0, (s.duration_s - 2.0 * cycles * ramp_time) / (2.0 * cycles + 1.0));
      p.t.push_back(hold);
      p.level.push_back(s.low_c);
      for (int c = 0; c < cycles; ++c) {
        p.go(s.high_c, s.ramp_c_per_s, hold);
        p.go(s.low_c, s.ramp_c_per_s, hold);
      }
      break;
    }
    case ChamberProfile::random_steps: {
      std::uniform_real_distribution<double> level(s.low_c, s.high_c);
      std::uniform_real_distribution<double> hold(1200.0, 3600.0);
      p.t.push_back(hold(rng));
      p.level.push_back(s.low_c);
      while (p.t.back() < s.duration_s) p.go(level(rng), s.ramp_c_per_s, hold(rng));
      break;
    }
  }
  return p;
}

}  // namespace

double table2_bias_mv(double temp_c) {
  static const std::array<double, 25> slopes = table2_slopes();
  const double u = (temp_c - kTable2FirstC) / kTable2StepC;
  if (u <= 0.0) return kTable2Mv.front() + slopes.front() * (temp_c - kTable2FirstC);
  if (u >= 24.0) return kTable2Mv.back() + slopes.back() * (temp_c - 80.0);
  const auto i = static_cast<std::size_t>(u);
  const double t = u - static_cast<double>(i);
  const double h00 = (1 + 2 * t) * (1 - t) * (1 - t);
  const double h10 = t * (1 - t) * (1 - t);
  const double h01 = t * t * (3 - 2 * t);
  const double h11 = t * t * (t - 1);
  return h00 * kTable2Mv[i] + h10 * kTable2StepC * slopes[i] + h01 * kTable2Mv[i + 1] +
         h11 * kTable2StepC * slopes[i + 1];
}

SeriesRecord generate_record(const RecordSpec& s) {
  std::mt19937_64 rng(s.seed);
  const Programme chamber = programme(s, rng);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> current(-s.tec_step_a, s.tec_step_a);
  std::uniform_real_distribution<double> tec_hold(600.0, 2400.0);

  const auto n = static_cast<std::size_t>(s.duration_s / s.sample_period_s);
  SeriesRecord r;
  r.time_s.reserve(n);
  double casing = chamber.at(0.0);
  model::GyroEffectState effects(s.effects);
  effects.reset(casing);
  const double innovation = s.noise == NoiseKind::ar1 ? std::sqrt(1.0 - s.ar1_rho * s.ar1_rho) : 1.0;
  double noise = s.noise_mv * normal(rng);
  double tec_a = 0.0;
  double next_tec_change = s.tec_step_a > 0.0 ? tec_hold(rng) : s.duration_s * 2;
  // A few sub-steps per sample keep the explicit casing update accurate.
  constexpr int kSubSteps = 4;
  const double h = s.sample_period_s / kSubSteps;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * s.sample_period_s;
    if (i > 0) {
      for (int k = 0; k < kSubSteps; ++k) {
        const double ts = t - s.sample_period_s + (k + 0.5) * h;
        const double heat_w = s.tec_pump_w_per_a * tec_a + model::tec_joule_heat_w(s.effects, tec_a);
        casing += h * (chamber.at(ts) - casing + s.casing_r_th_k_per_w * heat_w) / s.casing_tau_s;
      }
      effects.advance(s.sample_period_s, casing);
    }
    if (t >= next_tec_change) {
      tec_a = current(rng);
      next_tec_change = t + tec_hold(rng);
    }
    if (s.noise == NoiseKind::ar1) {
      noise = s.ar1_rho * noise + innovation * s.noise_mv * normal(rng);
    } else {
      noise = s.noise_mv * normal(rng);
    }
    const double sensor =
        s.quantise_sensor ? std::round(casing / kDs18b20StepC) * kDs18b20StepC : casing;
    effects.set_ambient_c(chamber.at(t));
    r.time_s.push_back(t);
    r.ambient_c.push_back(chamber.at(t));
    r.sensor_c.push_back(sensor);
    r.gyro_mv.push_back(table2_bias_mv(effects.bias_temp_c()) + effects.extra_bias_mv() + noise);
    r.tec_a.push_back(tec_a);
  }
  return r;
}

}  // namespace gyrotc::identify
