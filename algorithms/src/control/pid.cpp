#include "gyrotc/algorithms/control/pid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace gyrotc::control {

PidParams PidParams::from_gains(double kp, double ki, double kd, double period_s) {
  PidParams p;
  p.kp = kp;
  p.period_s = period_s;
  p.ti_s = kp * period_s / ki;  // KI = Kp*T/TI
  p.td_s = kd * period_s / kp;  // KD = Kp*TD/T
  return p;
}

void validate(const PidParams& p) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("PID " + what); };
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(p.kp) || p.kp <= 0.0) fail("kp must be a positive number");
  if (!finite(p.ti_s) || p.ti_s <= 0.0) fail("ti_s must be a positive number");
  if (!finite(p.td_s) || p.td_s < 0.0) fail("td_s must be zero or positive");
  if (!finite(p.period_s) || p.period_s <= 0.0) fail("period_s must be a positive number");
  if (!finite(p.xi_c) || p.xi_c < 0.0) fail("xi_c must be zero or positive");
  if (!finite(p.out_min) || !finite(p.out_max) || p.out_min >= p.out_max)
    fail("out_min must be below out_max");
}

IncrementalPid::IncrementalPid(const PidParams& params) : params_(params) {
  validate(params_);
  retune(params_);
  reset(0.0);
}

void IncrementalPid::retune(const PidParams& params) noexcept {
  params_ = params;
  const double t = params_.period_s;
  // Seed Eq. 17: A = Kp(1 + T/TI + TD/T), B = Kp(1 + 2TD/T), C = Kp TD/T; beta = 0 (Eq. 18) for a_pd.
  a_pid_ = params_.kp * (1.0 + t / params_.ti_s + params_.td_s / t);
  a_pd_ = params_.kp * (1.0 + params_.td_s / t);
  b_ = params_.kp * (1.0 + 2.0 * params_.td_s / t);
  c_ = params_.kp * params_.td_s / t;
  // state_ (the unclamped v) is the velocity form's memory: kept as it is.
  output_ = std::clamp(output_, params_.out_min, params_.out_max);
}

void IncrementalPid::reset(double output) noexcept {
  const double start = std::isfinite(output) ? output : 0.0;
  state_ = std::clamp(start, params_.out_min, params_.out_max);  // integral part
  output_ = state_;
  e1_ = 0.0;
  e2_ = 0.0;
  started_ = false;
  saturated_ = false;
  integrating_ = false;
}

double IncrementalPid::integral() const noexcept {
  // v = -(Kp e(k) + KD (e(k) - e(k-1))) + I after a step, e(k) = e1_, e(k-1) = e2_.
  return started_ ? state_ + params_.kp * e1_ + c_ * (e1_ - e2_) : state_;
}

double IncrementalPid::step(double measured, double setpoint) noexcept {
  return step(measured, setpoint, params_.out_min, params_.out_max);
}

double IncrementalPid::step(double measured, double setpoint, double out_min, double out_max) noexcept {
  if (!std::isfinite(measured) || !std::isfinite(setpoint)) return output_;
  if (!std::isfinite(out_min) || !std::isfinite(out_max)) {
    out_min = params_.out_min;
    out_max = params_.out_max;
  }
  out_max = std::max(out_min, out_max);
  const double e = measured - setpoint;  // seed: e(k) = c(k) - r(k)
  if (!started_) {
    // Bumpless: pretend the error has been e for ever, so the derivative is
    // zero and v(k-1) = -Kp e + I0 (the positional value with integral I0).
    e1_ = e;
    e2_ = e;
    state_ -= params_.kp * e;
    started_ = true;
  }
  // Output sign is opposite to Eq. 17's u: positive output heats.
  const double v_pd = state_ - (a_pd_ * e - b_ * e1_ + c_ * e2_);
  const double integral_step = -(a_pid_ - a_pd_) * e;  // -Kp T/TI e(k)
  // The seed's prototype (Section 4): PD when |e| >= the threshold (0.5 C), PID
  // below it. Its Eq. 18 text puts |e| = xi in the PID band; the board's
  // 1/16 C readings hit 0.5 C exactly, and the prototype is what we port.
  const bool in_band = std::fabs(e) < params_.xi_c;
  const bool winds_up = (v_pd >= out_max && integral_step > 0.0) || (v_pd <= out_min && integral_step < 0.0);
  integrating_ = in_band && !winds_up;
  state_ = integrating_ ? v_pd + integral_step : v_pd;
  output_ = std::clamp(state_, out_min, out_max);
  saturated_ = state_ > out_max || state_ < out_min;
  e2_ = e1_;
  e1_ = e;
  return output_;
}

}  // namespace gyrotc::control
