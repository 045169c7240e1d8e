#include "gyrotc/algorithms/tune/thermal_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gyrotc::tune {
namespace {

// Longest trapezoidal step: the shell's time constant is at least 2 s in an
// identified model, and a step longer than the time constant would ring.
constexpr double kMaxStepS = 2.0;

// The model's rates, computed once for a run of many steps.
struct Coefficients {
  double a, b, g, r, e, p, s_per_r, rail, limit, h, tau_b;
};

Coefficients coefficients(const ThermalModel& m) noexcept {
  return {m.peltier_per_a_s, m.joule_k_per_a2_s, m.casing_shell_per_s(), m.capacity_ratio(),
          m.shell_ambient_per_s(), m.internal_k_per_s, m.rail_a_per_c(), m.rail_a, m.stage_limit_a,
          m.side_per_s, m.side_tau_s};
}

ThermalMatrix matrix(const Coefficients& c, double i, double ambient_c) noexcept {
  return {c.a * i - c.g,
          c.g,
          c.r * c.g,
          -c.r * c.a * i - c.r * c.g - c.e,
          c.a * i * kKelvin + c.b * i * i + c.p,
          c.r * (-c.a * i * kKelvin + c.b * i * i) + c.e * ambient_c};
}

double applied(const Coefficients& c, const ThermalState& x, double command_a) noexcept {
  const double shift_a = c.s_per_r * (x.casing_c - x.shell_c);
  const double hi = c.rail - shift_a;
  const double lo = -c.rail - shift_a;
  // Clamps rounded over a few mA (softplus), so that the fit's least squares
  // see a smooth function of the rail's and the current limit's parameters.
  auto softplus = [](double v) { return v > 30.0 ? v : (v < -30.0 ? 0.0 : std::log1p(std::exp(v))); };
  constexpr double kRoundA = 0.003;
  auto clip = [&](double i, double low, double high) {
    return i - kRoundA * softplus((i - high) / kRoundA) + kRoundA * softplus((low - i) / kRoundA);
  };
  return clip(clip(command_a, lo, hi), -c.limit, c.limit);
}

ThermalState trapezoid(const Coefficients& c, const ThermalMatrix& k, const ThermalState& x, double h) noexcept {
  const double hh = 0.5 * h;
  double m11 = 1.0 - hh * k.a11;
  const double m12 = -hh * k.a12;
  const double m21 = -hh * k.a21;
  const double m22 = 1.0 - hh * k.a22;
  double r1 = x.casing_c + hh * (k.a11 * x.casing_c + k.a12 * x.shell_c) + h * k.b1;
  const double r2 = x.shell_c + hh * (k.a21 * x.casing_c + k.a22 * x.shell_c) + h * k.b2;
  if (c.h <= 0.0) {
    const double det = m11 * m22 - m12 * m21;
    return {(r1 * m22 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det};
  }
  // The side node's row, (1 + u) Tb' - u Tc' = r3 with u = hh / tau_b, solved
  // for Tb' and put into the casing's row: the same 2x2 system.
  const double u = hh / c.tau_b;
  const double r3 = x.side_c + u * (x.casing_c - x.side_c);
  m11 += hh * c.h * (1.0 - u / (1.0 + u));
  r1 += hh * c.h * (x.side_c - x.casing_c) + hh * c.h * r3 / (1.0 + u);
  const double det = m11 * m22 - m12 * m21;
  const double casing_c = (r1 * m22 - m12 * r2) / det;
  return {casing_c, (m11 * r2 - m21 * r1) / det, (r3 + u * casing_c) / (1.0 + u)};
}

// The side node, where the state leaves it unset, at the casing's temperature.
ThermalState with_side(const ThermalState& x) noexcept {
  ThermalState y = x;
  if (std::isnan(y.side_c)) y.side_c = y.casing_c;
  return y;
}

}  // namespace

double ThermalModel::casing_shell_per_s() const noexcept { return loss_per_s * (1.0 + shell_ratio) / shell_ratio; }

double ThermalModel::capacity_ratio() const noexcept {
  return 1.0 / (shell_tau_s * casing_shell_per_s() * (1.0 + shell_ratio));
}

double ThermalModel::shell_ambient_per_s() const noexcept {
  return shell_ratio * capacity_ratio() * casing_shell_per_s();
}

double ThermalModel::rail_a_per_c() const noexcept { return peltier_per_a_s / (2.0 * joule_k_per_a2_s); }

double ThermalModel::steady_reading_c(double casing_c, double ambient_c) const noexcept {
  return (1.0 - sensor_ambient_share) * casing_c + sensor_ambient_share * ambient_c;
}

double ThermalModel::casing_for_reading_c(double reading_c, double ambient_c) const noexcept {
  return (reading_c - sensor_ambient_share * ambient_c) / (1.0 - sensor_ambient_share);
}

ThermalMatrix thermal_matrix(const ThermalModel& m, double i, double ambient_c) noexcept {
  return matrix(coefficients(m), i, ambient_c);
}

double applied_current_a(const ThermalModel& m, const ThermalState& x, double command_a) noexcept {
  return applied(coefficients(m), x, command_a);
}

double casing_gain_k_per_a_s(const ThermalModel& m, const ThermalState& x, double current_a) noexcept {
  return m.peltier_per_a_s * (x.casing_c + kKelvin) + 2.0 * m.joule_k_per_a2_s * current_a;
}

ThermalState step(const ThermalModel& m, const ThermalState& x, double command_a, double ambient_c,
                  double h_s) noexcept {
  if (!(h_s > 0.0)) return x;
  const Coefficients c = coefficients(m);
  const int n = std::max(1, static_cast<int>(std::ceil(h_s / kMaxStepS - 1e-9)));
  const double h = h_s / n;
  ThermalState y = with_side(x);
  for (int j = 0; j < n; ++j) y = trapezoid(c, matrix(c, applied(c, y, command_a), ambient_c), y, h);
  return y;
}

ThermalState steady_state(const ThermalModel& m, double i, double ambient_c) noexcept {
  const ThermalMatrix k = thermal_matrix(m, i, ambient_c);
  const double det = k.a11 * k.a22 - k.a12 * k.a21;
  // A x = -b; the side node, without a heat source, at the casing's temperature.
  const double casing_c = (-k.b1 * k.a22 + k.a12 * k.b2) / det;
  return {casing_c, (-k.a11 * k.b2 + k.a21 * k.b1) / det, casing_c};
}

namespace {

// The steady state exists and is stable: A has a positive determinant and a
// negative trace (the Peltier term a I Tc can make the casing's balance run
// away at large heating currents).
bool stable_at(const ThermalModel& m, double i) noexcept {
  const ThermalMatrix k = thermal_matrix(m, i, 0.0);
  return k.a11 * k.a22 - k.a12 * k.a21 > 0.0 && k.a11 + k.a22 < 0.0;
}

}  // namespace

double holding_current_a(const ThermalModel& m, double reading_c, double ambient_c, double limit_a) noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(limit_a > 0.0)) return nan;
  const double casing_c = m.casing_for_reading_c(reading_c, ambient_c);
  auto excess = [&](double i) { return steady_state(m, i, ambient_c).casing_c - casing_c; };
  // Walk from 0 A towards heating or cooling until the steady casing
  // temperature passes the target; stop where the balance runs away or (when
  // cooling) where more current stops cooling (the Joule heat wins).
  const double direction = excess(0.0) < 0.0 ? 1.0 : -1.0;
  constexpr int kSteps = 400;
  double lo = 0.0;
  double lo_excess = excess(0.0);
  double hi = nan;
  for (int j = 1; j <= kSteps; ++j) {
    const double i = direction * limit_a * j / kSteps;
    if (!stable_at(m, i)) break;
    const double e = excess(i);
    if ((e - lo_excess) * direction <= 0.0) break;  // no longer moving towards the target
    if (e * direction >= 0.0) {
      hi = i;
      break;
    }
    lo = i;
    lo_excess = e;
  }
  if (std::isnan(hi)) return nan;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (excess(mid) * direction < 0.0 ? lo : hi) = mid;
  }
  const double i = 0.5 * (lo + hi);
  const ThermalState x = steady_state(m, i, ambient_c);
  if (std::fabs(applied_current_a(m, x, i) - i) > 1e-4) return nan;  // beyond the rails
  return i;
}

void simulate_sensor(const ThermalModel& m, const ThermalState& initial, std::span<const double> time_s,
                     std::span<const double> command_a, std::span<const double> ambient_c,
                     std::span<double> sensor_c, std::span<double> scratch) noexcept {
  const std::size_t n = time_s.size();
  if (n == 0) return;
  // What the sensor's lag follows, (1 - q) Tc + q Ta, lagged at every record
  // time (exact for an input moving linearly over the step).
  const Coefficients c = coefficients(m);
  ThermalState x = with_side(initial);
  scratch[0] = m.steady_reading_c(x.casing_c, ambient_c[0]);
  const double tau = m.sensor_lag_s;
  double last_h = -1.0;
  double decay = 0.0;
  double ramp = 1.0;
  for (std::size_t j = 1; j < n; ++j) {
    const double h_s = time_s[j] - time_s[j - 1];
    const double ta = 0.5 * (ambient_c[j - 1] + ambient_c[j]);
    const double before_c = m.steady_reading_c(x.casing_c, ambient_c[j - 1]);
    const int steps = std::max(1, static_cast<int>(std::ceil(h_s / kMaxStepS - 1e-9)));
    const double h = h_s / steps;
    for (int s = 0; s < steps; ++s) x = trapezoid(c, matrix(c, applied(c, x, command_a[j - 1]), ta), x, h);
    const double after_c = m.steady_reading_c(x.casing_c, ambient_c[j]);
    if (tau <= 0.0) {
      scratch[j] = after_c;
      continue;
    }
    if (h_s != last_h) {
      last_h = h_s;
      decay = std::exp(-h_s / tau);
      ramp = 1.0 - tau / h_s * (1.0 - decay);
    }
    scratch[j] = decay * scratch[j - 1] + (1.0 - decay) * before_c + (after_c - before_c) * ramp;
  }
  // The dead time: the reading at t is the lag's output at t - d.
  const double d = m.dead_time_s;
  std::size_t i = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const double t = time_s[j] - d;
    if (t <= time_s[0]) {
      sensor_c[j] = scratch[0];
      continue;
    }
    while (i + 1 < n && time_s[i + 1] < t) ++i;
    const double w = (t - time_s[i]) / (time_s[i + 1] - time_s[i]);
    sensor_c[j] = scratch[i] + w * (scratch[i + 1] - scratch[i]);
  }
}

}  // namespace gyrotc::tune
