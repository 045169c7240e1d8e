#include "gyrotc/algorithms/tune/controller_design.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>

#include "gyrotc/algorithms/control/pid.hpp"

namespace gyrotc::tune {
namespace {

using cd = std::complex<double>;
constexpr double kPi = 3.14159265358979323846;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The reading the controller gets: the DS18B20's 12-bit step.
double quantise(double temp_c, double step_c) { return std::nearbyint(temp_c / step_c) * step_c; }

// The linearised plant from TEC current to the sensed casing temperature at
// the operating point (holding the setpoint at ambient_c), without delays.
struct Linear {
  ThermalMatrix a;
  double b1, b2;  // d/dI of the network's right-hand side
  double side_per_s, side_tau_s;  // the side node (thermal_model.hpp)
  cd at(double w) const {
    const cd s(0.0, w);
    // The side node draws h (Tc - Tb), Tb = Tc / (1 + s tau_b), from the casing.
    const cd a11 = a.a11 - side_per_s * s * side_tau_s / (1.0 + s * side_tau_s);
    return ((s - a.a22) * b1 + a.a12 * b2) / ((s - a11) * (s - a.a22) - a.a12 * a.a21);
  }
};

Linear linearise(const ThermalModel& m, const DesignSpec& spec, double ambient_c) {
  double i0 = holding_current_a(m, spec.setpoint_c, ambient_c, std::max(spec.max_a, -spec.min_a));
  if (!std::isfinite(i0)) i0 = spec.max_a;
  const ThermalState x = steady_state(m, i0, ambient_c);
  const double a = m.peltier_per_a_s;
  const double b = m.joule_k_per_a2_s;
  return {thermal_matrix(m, i0, ambient_c), a * (x.casing_c + kKelvin) + 2.0 * b * i0,
          m.capacity_ratio() * (-a * (x.shell_c + kKelvin) + 2.0 * b * i0), m.side_per_s, m.side_tau_s};
}

// L(jw): PID (z = e^{jwT}), zero-order hold, plant, sensor lag, dead time and
// the reading's mean age (half a sensor period).
cd loop_at(const Linear& p, const ThermalModel& m, const DesignSpec& spec, const PidGains& k, double w) {
  const double t = spec.period_s;
  const cd zinv = std::exp(cd(0.0, -w * t));
  const cd pid = k.kp + k.ki / (1.0 - zinv) + k.kd * (1.0 - zinv);
  const cd zoh = std::abs(w * t) < 1e-12 ? cd(1.0) : (1.0 - zinv) / cd(0.0, w * t);
  const cd delay = std::exp(cd(0.0, -w * (m.dead_time_s + 0.5 * spec.sensor_period_s)));
  const cd lag = (1.0 - m.sensor_ambient_share) / cd(1.0, w * m.sensor_lag_s);
  return pid * zoh * p.at(w) * delay * lag;
}

ThermalModel scaled(ThermalModel m, double tec_gain, double rate) {
  m.peltier_per_a_s *= tec_gain * rate;
  m.joule_k_per_a2_s *= tec_gain * rate;
  m.loss_per_s *= rate;
  m.internal_k_per_s *= rate;
  m.shell_tau_s /= rate;
  return m;
}

}  // namespace

LoopMargins loop_margins(const ThermalModel& m, const DesignSpec& spec, const PidGains& k, double ambient_c) {
  const Linear p = linearise(m, spec, ambient_c);
  LoopMargins out;
  out.gain_margin = kInf;
  out.phase_margin_deg = kInf;
  // 40 points a decade from 1e-6 rad/s to Nyquist: the sensitivity peak
  // (near the crossover, ~0.1 rad/s) within a fraction of a percent.
  constexpr int kPoints = 240;
  const double w_lo = 1e-6;
  const double w_hi = kPi / spec.period_s;
  const double w_ratio = std::pow(w_hi / w_lo, 1.0 / kPoints);
  double w = w_lo / w_ratio;
  double unwrapped = 0.0;
  double last_arg = 0.0;
  double last_mag = kInf;
  double last_phase = 0.0;
  bool found_crossover = false;
  bool found_phase = false;
  for (int j = 0; j <= kPoints; ++j) {
    w *= w_ratio;
    const cd l = loop_at(p, m, spec, k, w);
    out.max_sensitivity = std::max(out.max_sensitivity, 1.0 / std::abs(1.0 + l));
    const double arg = std::arg(l);
    if (j == 0) {
      unwrapped = arg;
    } else {
      double d = arg - last_arg;
      while (d > kPi) d -= 2.0 * kPi;
      while (d < -kPi) d += 2.0 * kPi;
      unwrapped += d;
    }
    last_arg = arg;
    const double mag = std::abs(l);
    // Crossings between two grid points, interpolated in log frequency.
    if (!found_crossover && j > 0 && last_mag >= 1.0 && mag < 1.0) {
      found_crossover = true;
      const double f = std::log(last_mag) / (std::log(last_mag) - std::log(mag));
      out.crossover_rad_s = w / std::pow(w_ratio, 1.0 - f);
      out.phase_margin_deg = 180.0 + (last_phase + f * (unwrapped - last_phase)) * 180.0 / kPi;
    }
    if (!found_phase && j > 0 && last_phase > -kPi && unwrapped <= -kPi) {
      found_phase = true;
      const double f = (last_phase + kPi) / (last_phase - unwrapped);
      out.gain_margin = 1.0 / std::exp(std::log(last_mag) + f * (std::log(mag) - std::log(last_mag)));
    }
    last_mag = mag;
    last_phase = unwrapped;
  }
  return out;
}

LoopRun simulate_loop(const ThermalModel& m, const DesignSpec& spec, const PidGains& k, double ff_a_per_c,
                      double ff_lag_s, const control::RailLimit& rail) {
  control::PidParams params = control::PidParams::from_gains(k.kp, k.ki, k.kd, spec.period_s);
  params.xi_c = k.xi_c;
  params.out_min = spec.min_a;
  params.out_max = spec.max_a;
  control::IncrementalPid pid(params);

  const double dt = spec.sensor_period_s;
  // The lagged sensor input ((1 - q) Tc + q Ta) of the last few seconds, for the dead time.
  constexpr std::size_t kHistory = 32;
  std::array<double, kHistory> history{};
  ThermalState x{spec.room_c, spec.room_c};  // power-on: the unit at the room's temperature
  double lagged = m.steady_reading_c(x.casing_c, spec.room_c);
  history.fill(lagged);
  std::size_t head = 0;
  const double lag_decay = m.sensor_lag_s > 0.0 ? std::exp(-dt / m.sensor_lag_s) : 0.0;
  const double delay_steps = std::min(m.dead_time_s / dt, static_cast<double>(kHistory - 2));

  LoopRun run;
  double band_start = -1.0;
  double programme_start = kInf;  // the chamber's excursions start once the warm-up has settled
  constexpr double kMaxWarmUpS = 7200.0;
  const double down_s = (spec.room_c - spec.rated_low_c) / spec.chamber_ramp_c_per_s;
  const double across_s = (spec.rated_high_c - spec.rated_low_c) / spec.chamber_ramp_c_per_s;
  auto ambient_at = [&](double t) {
    double u = t - programme_start;
    if (u <= 0.0) return spec.room_c;
    if (u < down_s) return spec.room_c - spec.chamber_ramp_c_per_s * u;
    u -= down_s;
    if (u < spec.hold_s) return spec.rated_low_c;
    u -= spec.hold_s;
    if (u < across_s) return spec.rated_low_c + spec.chamber_ramp_c_per_s * u;
    return spec.rated_high_c;
  };
  double ambient_reading = quantise(spec.room_c, spec.sensor_step_c);
  control::AmbientLag ff_ambient;
  ff_ambient.update(ambient_reading, 0.0, ff_lag_s);
  double command = 0.0;
  double next_pid = spec.period_s;
  double next_ambient = 0.0;
  for (double t = 0.0;; t += dt) {
    const double ambient = ambient_at(t);
    if (programme_start == kInf && (t > kMaxWarmUpS || (run.settle_s >= 0.0 && t >= run.settle_s + spec.settle_hold_s + 300.0))) {
      programme_start = t;
      if (run.settle_s < 0.0) break;
    }
    if (programme_start < kInf && t - programme_start > down_s + across_s + 2.0 * spec.hold_s) break;
    if (spec.ambient_sensor && t >= next_ambient) {
      ambient_reading = quantise(ambient, spec.sensor_step_c);
      ff_ambient.update(ambient_reading, spec.ambient_period_s, ff_lag_s);
      next_ambient += spec.ambient_period_s;
    }
    if (t >= next_pid - 1e-9) {
      // The reading: the lagged sensor input dead_time_s ago, in DS18B20 steps.
      const double back = delay_steps;
      const auto whole = static_cast<std::size_t>(back);
      const double frac = back - static_cast<double>(whole);
      const double newer = history[(head + kHistory - whole) % kHistory];
      const double older = history[(head + kHistory - whole - 1) % kHistory];
      const double reading = quantise(newer + frac * (older - newer), spec.sensor_step_c);
      const double amb = spec.ambient_sensor ? ambient_reading : kNan;
      const control::CurrentRange range = control::applied_range(spec.min_a, spec.max_a, rail, reading, amb);
      const double ff_amb = spec.ambient_sensor ? ff_ambient.value_c() : kNan;
      command = control::pid_current_a(pid, reading, spec.setpoint_c,
                                       control::feed_forward_a(ff_a_per_c, spec.setpoint_c, ff_amb), range);
      next_pid += spec.period_s;
    }
    x = step(m, x, command, ambient, dt);
    const double followed_c = m.steady_reading_c(x.casing_c, ambient);
    lagged = m.sensor_lag_s > 0.0 ? lag_decay * lagged + (1.0 - lag_decay) * followed_c : followed_c;
    head = (head + 1) % kHistory;
    history[head] = lagged;

    const double now = t + dt;
    const double error = std::fabs(m.steady_reading_c(x.casing_c, ambient) - spec.setpoint_c);
    if (!std::isfinite(error)) {
      run.settle_s = -1.0;
      break;
    }
    if (run.settle_s < 0.0) {
      if (error <= spec.settle_band_c) {
        if (band_start < 0.0) band_start = now;
        if (now - band_start >= spec.settle_hold_s) run.settle_s = band_start;
      } else {
        band_start = -1.0;
      }
    } else if (now >= run.settle_s + spec.settle_hold_s) {
      run.max_error_c = std::max(run.max_error_c, error);
      const double a = ambient_at(now);
      if (a >= spec.band_low_c && a <= spec.band_high_c) {
        run.max_error_in_band_c = std::max(run.max_error_in_band_c, error);
      }
    }
  }
  return run;
}

double minimum_settle_s(const ThermalModel& m, const DesignSpec& spec) {
  ThermalState x{spec.room_c, spec.room_c};
  const double target = m.casing_for_reading_c(spec.setpoint_c - spec.settle_band_c, spec.room_c);
  constexpr double kStepS = 0.5;
  for (double t = 0.0; t < 3.0 * 3600.0; t += kStepS) {
    const ThermalState next = step(m, x, spec.max_a, spec.room_c, kStepS);
    if (next.casing_c >= target) {
      return t + kStepS * (target - x.casing_c) / (next.casing_c - x.casing_c);
    }
    x = next;
  }
  return -1.0;
}

double stuck_min_drive_a(const ThermalModel& m, const DesignSpec& spec) {
  const double limit_a = std::max(spec.max_a, -spec.min_a);
  double max_hold = 0.0;
  for (double ta = spec.rated_low_c; ta <= spec.rated_high_c + 1e-9; ta += 5.0) {
    const double h = holding_current_a(m, spec.setpoint_c, ta, limit_a);
    if (std::isfinite(h)) max_hold = std::max(max_hold, std::fabs(h));
  }
  return control::stuck_drive_threshold_a(max_hold, limit_a);
}

ControllerDesign design_controller(const ThermalModel& m, const DesignSpec& requested) {
  ControllerDesign d;
  const double limit_a = std::max(requested.max_a, -requested.min_a);
  for (double ta = requested.rated_low_c; ta <= requested.rated_high_c + 1e-9; ta += 5.0) {
    d.holding_ambient_c.push_back(ta);
    d.holding_a.push_back(holding_current_a(m, requested.setpoint_c, ta, limit_a));
  }
  const double hold_room = holding_current_a(m, requested.setpoint_c, requested.room_c, limit_a);
  if (!std::isfinite(hold_room) || hold_room > requested.max_a || hold_room < requested.min_a) {
    throw std::invalid_argument("the identified unit cannot hold the setpoint at the record's ambient within its "
                                "current limits: nothing to design a loop for");
  }
  // Design for the ambients the unit can hold: beyond them no gains help, and
  // an error the stage cannot avoid would decide the gains at random.
  DesignSpec spec = requested;
  for (std::size_t j = 0; j < d.holding_ambient_c.size(); ++j) {
    const double ta = d.holding_ambient_c[j];
    if (std::isfinite(d.holding_a[j])) continue;
    if (ta < spec.room_c) spec.rated_low_c = std::max(spec.rated_low_c, ta + 5.0);
    if (ta > spec.room_c) spec.rated_high_c = std::min(spec.rated_high_c, ta - 5.0);
  }
  spec.rated_low_c = std::min(spec.rated_low_c, spec.room_c);
  spec.rated_high_c = std::max(spec.rated_high_c, spec.room_c);
  spec.band_low_c = std::max(spec.band_low_c, spec.rated_low_c);
  spec.band_high_c = std::min(spec.band_high_c, spec.rated_high_c);
  if (spec.rail_known) {
    // The Controller takes the ambient reading for the shell it cannot see.
    // Holding a large difference the conduction through the module warms the
    // shell above the ambient, and the stage gives more than that estimate:
    // shift the rail by the largest such excess (and 1 K), so the estimate
    // errs on the side of more current (a small windup) and never withholds
    // current the stage has.
    double excess_k = 0.0;
    for (std::size_t j = 0; j < d.holding_ambient_c.size(); ++j) {
      if (!std::isfinite(d.holding_a[j])) continue;
      const ThermalState x = steady_state(m, d.holding_a[j], d.holding_ambient_c[j]);
      excess_k = std::max(excess_k, x.shell_c - d.holding_ambient_c[j]);
    }
    const double shift_a = m.rail_a_per_c() * (excess_k + 1.0);
    d.rail.known = true;
    d.rail.pos_a = m.rail_a + shift_a;
    d.rail.neg_a = -m.rail_a - shift_a;
    d.rail.a_per_c = m.rail_a_per_c();
  }
  // Feed-forward: the Controller's form is a line through zero against
  // (setpoint - ambient). Two slopes are candidates for the search below: the
  // line through zero that best matches the holding current over the band,
  // and the holding current's own slope there (a straight line with an
  // offset, the offset left to the integral). Where the unit's own heat moves
  // the holding current's line away from zero, the first answers a chamber
  // ramp with the wrong current and the error lasts until the integral
  // catches up; the design programme's ramps decide (tune_suite: network 8
  // from 0.27 C to 0.12 C, docs/TUNING.md).
  std::vector<double> ff_slopes{0.0};
  if (spec.ambient_sensor) {
    double sx = 0.0, sy = 0.0, sxy = 0.0, sxx = 0.0, count = 0.0;
    for (std::size_t j = 0; j < d.holding_ambient_c.size(); ++j) {
      const double ta = d.holding_ambient_c[j];
      if (ta < spec.band_low_c || ta > spec.band_high_c || !std::isfinite(d.holding_a[j])) continue;
      const double xv = spec.setpoint_c - ta;
      sx += xv;
      sy += d.holding_a[j];
      sxy += xv * d.holding_a[j];
      sxx += xv * xv;
      count += 1.0;
    }
    const double through_zero = sxx > 0.0 ? sxy / sxx : 0.0;
    const double spread = sxx - sx * sx / std::max(count, 1.0);
    ff_slopes = {through_zero};
    if (count >= 2.0 && spread > 0.0) {
      const double own = (sxy - sx * sy / count) / spread;
      if (std::fabs(own - through_zero) > 0.02 * std::fabs(through_zero)) ff_slopes.push_back(own);
    }
    // A change of the ambient reaches the held casing through the shell:
    // the feed-forward answers the ambient as the shell does, when the
    // record has pinned the shell down (a shell it has not is a guess, and a
    // guessed lag of an hour would hold the feed-forward back all programme).
    d.feed_forward_lag_s = spec.shell_known ? m.shell_tau_s : 0.0;
  }
  d.stuck_min_drive_a = stuck_min_drive_a(m, requested);
  d.minimum_settle_s = minimum_settle_s(m, spec);

  // Gain candidates on the unit's own scale: 1 / (TEC gain x loop delay).
  const ThermalState at_setpoint = steady_state(m, hold_room, spec.room_c);
  const double gain = casing_gain_k_per_a_s(m, at_setpoint, hold_room);
  const double delay = m.dead_time_s + m.sensor_lag_s + 0.5 * spec.period_s + 0.5 * spec.sensor_period_s;
  const double kp_ref = 1.0 / (gain * delay);
  const std::array<std::pair<const char*, ThermalModel>, 5> perturbed = {{
      {"TEC gain x0.5", scaled(m, 0.5, 1.0)},
      {"TEC gain x2", scaled(m, 2.0, 1.0)},
      {"heat capacity x2", scaled(m, 1.0, 0.5)},
      {"heat capacity x0.5", scaled(m, 1.0, 2.0)},
      {"dead time +4 s", [&] {
         ThermalModel p = m;
         p.dead_time_s += 4.0;
         return p;
       }()},
  }};
  struct Scored {
    PidGains gains;
    double ff_a_per_c;
    LoopRun run;
  };
  std::vector<Scored> scored;
  constexpr double kXiSearch = 1.0;
  for (double kp_factor : {0.04, 0.06, 0.1, 0.15, 0.25, 0.4, 0.6}) {
    for (double ti_s : {40.0, 80.0, 160.0, 320.0, 640.0}) {
      for (double td_fraction : {0.0, 0.5, 1.0}) {
        PidGains k;
        k.kp = kp_factor * kp_ref;
        k.ki = k.kp * spec.period_s / ti_s;
        k.kd = k.kp * td_fraction;
        k.xi_c = kXiSearch;
        ++d.candidates;
        double ms = 0.0;
        for (double ta : {spec.band_low_c, spec.room_c, spec.band_high_c}) {
          ms = std::max(ms, loop_margins(m, spec, k, ta).max_sensitivity);
        }
        if (!(ms <= spec.max_sensitivity)) continue;
        bool robust = true;
        for (const auto& [name, pm] : perturbed) {
          robust = robust && loop_margins(pm, spec, k, spec.room_c).max_sensitivity <= spec.max_sensitivity_perturbed;
        }
        if (!robust) continue;
        ++d.robust_candidates;
        for (double ff : ff_slopes) scored.push_back({k, ff, simulate_loop(m, spec, k, ff, d.feed_forward_lag_s, d.rail)});
      }
    }
  }
  auto settled = [](const Scored& s) { return s.run.settle_s >= 0.0; };
  double best_error = kInf;
  for (const auto& s : scored) {
    if (settled(s)) best_error = std::min(best_error, s.run.max_error_in_band_c);
  }
  if (!std::isfinite(best_error)) {
    throw std::invalid_argument("no robust gains settle the identified unit at the setpoint");
  }
  const Scored* pick = nullptr;
  for (const auto& s : scored) {
    if (!settled(s) || s.run.max_error_in_band_c > best_error + 0.003) continue;
    if (pick == nullptr || s.run.settle_s < pick->run.settle_s ||
        (s.run.settle_s == pick->run.settle_s && s.run.max_error_in_band_c < pick->run.max_error_in_band_c)) {
      pick = &s;
    }
  }
  d.gains = pick->gains;
  d.feed_forward_a_per_c = pick->ff_a_per_c;
  d.predicted = pick->run;
  // The separation band: the fastest settling that keeps the error.
  for (double xi : {0.25, 0.5, 2.0, 4.0}) {
    PidGains k = pick->gains;
    k.xi_c = xi;
    const LoopRun run = simulate_loop(m, spec, k, d.feed_forward_a_per_c, d.feed_forward_lag_s, d.rail);
    if (run.settle_s >= 0.0 && run.settle_s < d.predicted.settle_s &&
        run.max_error_in_band_c <= d.predicted.max_error_in_band_c + 0.003) {
      d.gains = k;
      d.predicted = run;
    }
  }
  d.margins = loop_margins(m, spec, d.gains, spec.room_c);
  for (const auto& [name, pm] : perturbed) {
    d.perturbed.push_back({name, loop_margins(pm, spec, d.gains, spec.room_c).max_sensitivity});
  }
  return d;
}

}  // namespace gyrotc::tune
