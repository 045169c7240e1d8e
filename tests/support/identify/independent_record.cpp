#include "independent_record.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

namespace gyrotc::identify_test {
namespace {

constexpr double kStepS = 0.5;           // integration step
constexpr double kQuantumC = 0.0625;     // DS18B20 12-bit step
constexpr double kConversionS = 0.75;    // DS18B20 12-bit conversion time
constexpr double kRelaxationAboveC = 50.0;
constexpr double kRelaxationTauS = 1800.0;

// Zero-rate output (mV) at the die temperature: a smooth curve unlike seed
// Table 2 (slope +0.9 mV/C at 20 C, curving down, with a ripple).
double bias_mv(double temp_c) {
  const double x = temp_c - 20.0;
  return 80.0 + 0.9 * x - 0.012 * x * x + 2.5 * std::sin((temp_c + 30.0) / 14.0);
}

// Chamber programme: a hold at 20 C, then ramps at random rates to random
// levels with random holds, until the end.
struct Chamber {
  std::vector<double> t, level;
  double at(double time) const {
    if (time >= t.back()) return level.back();
    const auto i = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin());
    if (i == 0) return level.front();
    const double f = (time - t[i - 1]) / (t[i] - t[i - 1]);
    return level[i - 1] + f * (level[i] - level[i - 1]);
  }
};

Chamber chamber_programme(const IndependentSpec& s, std::mt19937_64& rng) {
  if (!s.programme.empty()) {
    Chamber c;
    for (const auto& [time_s, level_c] : s.programme) {
      c.t.push_back(time_s);
      c.level.push_back(level_c);
    }
    return c;
  }
  std::uniform_real_distribution<double> level(s.low_c, s.high_c);
  std::uniform_real_distribution<double> rate(s.min_ramp_c_per_min / 60.0, s.max_ramp_c_per_min / 60.0);
  std::uniform_real_distribution<double> hold(600.0, 2400.0);
  Chamber c{{0.0, 1200.0}, {20.0, 20.0}};
  while (c.t.back() < s.duration_s) {
    double to = level(rng);
    while (std::fabs(to - c.level.back()) < 0.2 * (s.high_c - s.low_c)) to = level(rng);
    if (c.t.size() == 2 && std::isfinite(s.first_level_c)) to = s.first_level_c;
    c.t.push_back(c.t.back() + std::fabs(to - c.level.back()) / rate(rng));
    c.level.push_back(to);
    c.t.push_back(c.t.back() + hold(rng));
    c.level.push_back(to);
  }
  return c;
}

bool in_gap(const IndependentSpec& s, double t) {
  return std::any_of(s.gaps.begin(), s.gaps.end(),
                     [t](const auto& g) { return t >= g.first && t < g.first + g.second; });
}

}  // namespace

identify::SeriesRecord make_independent_record(const IndependentSpec& s) {
  std::mt19937_64 rng(s.seed ^ 0x9e3779b97f4a7c15ULL);
  const Chamber chamber = chamber_programme(s, rng);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-s.jitter_s, s.jitter_s);

  double shell = chamber.at(0.0);
  double casing = shell;
  double die = casing;
  double wander = s.wander_mv * normal(rng);
  double relax_start = -1.0;
  // Casing temperatures of the last kConversionS, for the late DS18B20 read.
  std::vector<std::pair<double, double>> history{{0.0, casing}};

  identify::SeriesRecord r;
  double t = 0.0;
  double next_sample = 0.0;
  double rate = 0.0;
  while (next_sample < s.duration_s) {
    const double sample_at = std::max(t, next_sample + (s.jitter_s > 0.0 ? jitter(rng) : 0.0));
    while (t + kStepS <= sample_at) {
      const double ambient = chamber.at(t + 0.5 * kStepS);
      const double shell_next = shell + kStepS * (ambient - shell) / s.shell_tau_s;
      const double casing_next = casing + kStepS * (shell - casing) / s.casing_tau_s;
      rate = (casing_next - casing) / kStepS;
      if (s.lag_tau_s > 0.0) {
        const double decay = std::exp(-kStepS / s.lag_tau_s);
        die = casing_next - rate * s.lag_tau_s + (die - casing + rate * s.lag_tau_s) * decay;
      } else {
        die = casing_next;
      }
      shell = shell_next;
      casing = casing_next;
      if (s.wander_mv > 0.0) {
        const double phi = std::exp(-kStepS / s.wander_tau_s);
        wander = phi * wander + s.wander_mv * std::sqrt(1.0 - phi * phi) * normal(rng);
      }
      t += kStepS;
      if (relax_start < 0.0 && casing > kRelaxationAboveC) relax_start = t;
      history.emplace_back(t, casing);
      while (history.size() > 2 && history[1].first <= t - kConversionS) history.erase(history.begin());
    }
    const double sampled = next_sample;
    next_sample += s.sample_period_s;
    if (in_gap(s, sampled)) continue;

    double mv = bias_mv(die) + wander + s.white_mv * normal(rng);
    mv += s.rate_mv_per_c_per_s * rate;
    if (s.hysteresis_mv != 0.0) mv += s.hysteresis_mv * std::tanh(rate / s.hysteresis_r0_c_per_s);
    mv += s.warm_up_mv * std::exp(-t / s.warm_up_tau_s);
    mv += s.drift_mv_per_h * t / 3600.0;
    mv += s.ambient_mv_per_c * (chamber.at(t) - 25.0);
    mv += s.periodic_mv * std::sin(2.0 * std::numbers::pi * t / s.periodic_s);
    if (relax_start >= 0.0) mv += s.relaxation_mv * (1.0 - std::exp(-(t - relax_start) / kRelaxationTauS));
    if (t >= s.step_at_s) mv += s.step_mv;
    mv += s.rate_squared_mv * (rate * 60.0) * (rate * 60.0);

    const double read_c = std::round(history.front().second / kQuantumC) * kQuantumC;
    r.time_s.push_back(t);
    r.ambient_c.push_back(chamber.at(t));
    r.sensor_c.push_back(read_c);
    r.gyro_mv.push_back(mv);
  }
  return r;
}

namespace {

// 20 C, then -30 -> 70 -> -30 -> 20 C at 0.5 C/min with 30 min holds, 12.5 h.
IndependentSpec on_a_triangle(std::uint64_t seed) {
  IndependentSpec s;
  s.programme = {{0.0, 20.0},      {1800.0, 20.0},  {7800.0, -30.0},  {9600.0, -30.0}, {21600.0, 70.0},
                 {23400.0, 70.0}, {35400.0, -30.0}, {37200.0, -30.0}, {43200.0, 20.0}};
  s.duration_s = 45000.0;
  s.seed = seed;
  return s;
}

}  // namespace

IndependentSpec hysteresis_on_a_triangle(std::uint64_t seed) {
  IndependentSpec s = on_a_triangle(seed);
  s.hysteresis_mv = 2.0;
  return s;
}

IndependentSpec lag_and_warm_up_on_a_triangle(std::uint64_t seed) {
  IndependentSpec s = on_a_triangle(seed);
  s.wander_mv = 0.4;
  s.wander_tau_s = 200.0;
  s.lag_tau_s = 250.0;
  s.warm_up_mv = 8.0;
  s.warm_up_tau_s = 600.0;
  return s;
}

IndependentSpec narrow_range(std::uint64_t seed) {
  IndependentSpec s;
  s.programme = {{0.0, 36.0}, {1800.0, 36.0}};
  double level = 30.0;
  while (s.programme.back().first < 6.0 * 3600.0) {
    const double t = s.programme.back().first + std::fabs(level - s.programme.back().second) / 0.5 * 60.0;
    s.programme.push_back({t, level});
    s.programme.push_back({t + 1200.0, level});
    level = level == 30.0 ? 42.0 : 30.0;
  }
  s.duration_s = s.programme.back().first;
  s.seed = seed;
  return s;
}

}  // namespace gyrotc::identify_test
