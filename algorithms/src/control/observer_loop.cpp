#include "gyrotc/algorithms/control/observer_loop.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "gyrotc/algorithms/control/riccati.hpp"
#include "gyrotc/algorithms/text/printf_string.hpp"

namespace gyrotc::control {
namespace {

// The held temperature in the steady state at current_a (into x); +inf
// where the housing is not stable at that current (an identified model's
// Peltier term outgrowing its losses: the casing, or the sink and with it
// the casing, heats without bound).
double held_c(HousingStepper& stepper, Eigen::VectorXd& x, double current_a, double ambient_c,
              double heat_w) noexcept {
  return stepper.steady_state(x, HousingInput{current_a, ambient_c, heat_w})
             ? stepper.controlled_c(x)
             : std::numeric_limits<double>::infinity();
}

// How close to the setpoint a steady state holds it.
constexpr double kHoldsC = 1e-3;

// The current in [min_a, max_a] whose steady state holds setpoint_c, or the
// one that comes closest where none does; its steady state in xss. The held
// temperature falls with the current only past the TEC's maximum cooling,
// where Joule heat wins (and a cooling current can warm the casing through a
// hot shell): the holding current is the root where it rises. Newton from
// `start_a` finds it in a few steps; where it does not (a root outside the
// range, an iterate past the maximum cooling), the range is searched: the
// maximum cooling (the held temperature's one minimum, golden section), then
// the root above it (bisection). The range stays within the stage's own
// limit: past it the steady state no longer moves with the command.
double steady_current(HousingStepper& stepper, Eigen::VectorXd& xss, Eigen::VectorXd& probe, double setpoint_c,
                      double ambient_c, double heat_w, double start_a, double min_a, double max_a) noexcept {
  constexpr double kDeltaA = 1e-3;
  const double limit_a = stepper.model().current_limit_a;
  min_a = std::clamp(min_a, -limit_a, limit_a);
  max_a = std::clamp(max_a, -limit_a, limit_a);
  double current_a = std::clamp(start_a, min_a, max_a);
  for (int k = 0; k < 12; ++k) {
    const double error_c = held_c(stepper, xss, current_a, ambient_c, heat_w) - setpoint_c;
    // The slope on the side within the range (at max_a, from below).
    const double delta_a = current_a + kDeltaA <= max_a ? kDeltaA : -kDeltaA;
    const double slope =
        (held_c(stepper, probe, current_a + delta_a, ambient_c, heat_w) - (error_c + setpoint_c)) / delta_a;
    if (!std::isfinite(slope) || !(slope > 0.0)) break;
    const double next_a = std::clamp(current_a - error_c / slope, min_a, max_a);
    if (std::fabs(next_a - current_a) < 1e-7) {
      if (std::fabs(held_c(stepper, xss, next_a, ambient_c, heat_w) - setpoint_c) <= kHoldsC) return next_a;
      break;  // at the range's end: the root lies beyond it
    }
    current_a = next_a;
  }
  const auto at = [&](double a) { return held_c(stepper, probe, a, ambient_c, heat_w); };
  constexpr double kGolden = 0.6180339887498949;
  double lo_a = min_a;
  double hi_a = max_a;
  double left_a = hi_a - kGolden * (hi_a - lo_a);
  double right_a = lo_a + kGolden * (hi_a - lo_a);
  double left_c = at(left_a);
  double right_c = at(right_a);
  for (int k = 0; k < 48; ++k) {
    if (left_c <= right_c) {
      hi_a = right_a;
      right_a = left_a;
      right_c = left_c;
      left_a = hi_a - kGolden * (hi_a - lo_a);
      left_c = at(left_a);
    } else {
      lo_a = left_a;
      left_a = right_a;
      left_c = right_c;
      right_a = lo_a + kGolden * (hi_a - lo_a);
      right_c = at(right_a);
    }
  }
  const double coolest_a = 0.5 * (lo_a + hi_a);
  if (at(coolest_a) >= setpoint_c) {
    current_a = coolest_a;  // no current cools the casing to the setpoint
  } else if (at(max_a) <= setpoint_c) {
    current_a = max_a;  // nor heats it
  } else {
    lo_a = coolest_a;
    hi_a = max_a;
    for (int k = 0; k < 52; ++k) {
      const double mid_a = 0.5 * (lo_a + hi_a);
      (at(mid_a) < setpoint_c ? lo_a : hi_a) = mid_a;
    }
    current_a = 0.5 * (lo_a + hi_a);
  }
  held_c(stepper, xss, current_a, ambient_c, heat_w);
  return current_a;
}

// Differences for the linearisation: the network is affine in the state with
// the current held, so any step is exact there; the current and the TEC's
// rail clipping are not.
constexpr double kStateDeltaC = 0.01;
constexpr double kHeatDeltaW = 0.01;
constexpr double kAmbientDeltaC = 0.01;

// The period's transition of (state, heat, ambient) at z with current_a,
// linearised: f (size n + 2), and the state after the period in `base`.
void linearise(HousingStepper& stepper, const Eigen::VectorXd& z, double current_a, double period_s,
               Eigen::MatrixXd& f, Eigen::VectorXd& base, Eigen::VectorXd& x) noexcept {
  const int n = stepper.model().state_count();
  const double heat_w = z(n);
  const double ambient_c = z(n + 1);
  const HousingInput in{current_a, ambient_c, heat_w};
  base = z.head(n);
  stepper.advance(base, period_s, in);
  f.setZero();
  for (int j = 0; j < n; ++j) {
    x = z.head(n);
    x(j) += kStateDeltaC;
    stepper.advance(x, period_s, in);
    f.col(j).head(n) = (x - base) / kStateDeltaC;
  }
  x = z.head(n);
  stepper.advance(x, period_s, HousingInput{current_a, ambient_c, heat_w + kHeatDeltaW});
  f.col(n).head(n) = (x - base) / kHeatDeltaW;
  x = z.head(n);
  stepper.advance(x, period_s, HousingInput{current_a, ambient_c + kAmbientDeltaC, heat_w});
  f.col(n + 1).head(n) = (x - base) / kAmbientDeltaC;
  f(n, n) = 1.0;
  f(n + 1, n + 1) = 1.0;
}

// Which entry of (state, heat, ambient) each sensor reads.
int casing_seen_index(const HousingModel& m) {
  return m.has_lag() ? m.casing_lag_index() : m.network.casing_sensor.node;
}
int ambient_seen_index(const HousingModel& m) {
  if (m.has_ambient_lag()) return m.ambient_lag_index();
  const int node = m.network.ambient_sensor.node;
  return node == model::kAmbientNode ? m.state_count() + 1 : node;
}

Eigen::MatrixXd process_noise(const ObserverLoopSpec& spec, int n) {
  Eigen::MatrixXd w = Eigen::MatrixXd::Zero(n + 2, n + 2);
  for (int i = 0; i < n; ++i) w(i, i) = spec.node_c_per_sqrt_s * spec.node_c_per_sqrt_s * spec.period_s;
  w(n, n) = spec.disturbance_w_per_sqrt_s * spec.disturbance_w_per_sqrt_s * spec.period_s;
  w(n + 1, n + 1) = spec.ambient_c_per_sqrt_s * spec.ambient_c_per_sqrt_s * spec.period_s;
  return w;
}

// Rounding leaves a covariance slightly asymmetric; in place, without a temporary.
void symmetrise(Eigen::MatrixXd& p) noexcept {
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < p.cols(); ++j) p(i, j) = p(j, i) = 0.5 * (p(i, j) + p(j, i));
  }
}

// P(N(0, 1) > x), accurate far into the tail.
double upper_tail(double x) noexcept { return 0.5 * std::erfc(x / std::sqrt(2.0)); }

// A reading's noise for the quantised update, at least floor_steps of a step:
// readings that stay on one step are not independent draws, and matching the
// same interval's moments period after period would shrink the covariance
// without bound (a filter sure of a temperature its readings cannot resolve).
double quantised_noise_var(double noise_c, double step_c, double floor_steps) {
  return std::max(noise_c * noise_c, floor_steps * floor_steps * step_c * step_c) + 1e-12;
}

double reading_variance(double noise_c, double step_c) { return noise_c * noise_c + step_c * step_c / 12.0 + 1e-12; }

}  // namespace

double holding_current_a(const HousingModel& model, double setpoint_c, double ambient_c, double limit_a) {
  HousingStepper stepper(model, 1.0);
  Eigen::VectorXd xss(model.state_count());
  Eigen::VectorXd probe(model.state_count());
  const double current_a = steady_current(stepper, xss, probe, setpoint_c, ambient_c, 0.0, 0.0, -limit_a, limit_a);
  return std::fabs(stepper.controlled_c(xss) - setpoint_c) <= kHoldsC ? current_a : std::nan("");
}

ObserverLoopDesign design_observer_loop(const HousingModel& model, const ObserverLoopSpec& spec) {
  if (!(spec.period_s > 0.0) || !(spec.reading_step_c >= 0.0) || !(spec.reading_noise_c >= 0.0) ||
      !(spec.ambient_noise_c >= 0.0) || !(spec.noise_floor_steps >= 0.0) || !(spec.disturbance_w_per_sqrt_s > 0.0) || !(spec.ambient_c_per_sqrt_s > 0.0) ||
      !(spec.node_c_per_sqrt_s > 0.0) || !(spec.error_scale_c > 0.0) || !(spec.current_scale_a > 0.0) ||
      !(spec.initial_heat_w > 0.0)) {
    throw std::invalid_argument("observer loop: the period, noises and weights must be positive");
  }
  if (!(spec.casing_weight >= 0.0)) throw std::invalid_argument("observer loop: the casing's weight must be 0 or more");
  HousingStepper stepper(model, spec.max_step_s);
  ObserverLoopDesign d;
  d.model = model;
  d.spec = spec;
  const int n = model.state_count();
  Eigen::VectorXd x0(n);
  Eigen::VectorXd probe(n);
  constexpr double kSearchA = 50.0;  // wide: steady_current keeps the current within the stage's limit
  d.operating_current_a = steady_current(stepper, x0, probe, spec.setpoint_c, spec.design_ambient_c, 0.0, 0.0,
                                         -kSearchA, kSearchA);
  if (std::fabs(stepper.controlled_c(x0) - spec.setpoint_c) > kHoldsC) {
    throw std::invalid_argument("observer loop: no TEC current holds the setpoint at the design ambient");
  }

  Eigen::VectorXd z0(n + 2);
  z0 << x0, 0.0, spec.design_ambient_c;
  Eigen::MatrixXd f(n + 2, n + 2);
  Eigen::VectorXd base(n);
  Eigen::VectorXd scratch(n);
  linearise(stepper, z0, d.operating_current_a, spec.period_s, f, base, scratch);
  const Eigen::MatrixXd phi = f.topLeftCorner(n, n);
  constexpr double kDeltaA = 1e-3;
  Eigen::VectorXd up = x0;
  Eigen::VectorXd down = x0;
  stepper.advance(up, spec.period_s, HousingInput{d.operating_current_a + kDeltaA, spec.design_ambient_c, 0.0});
  stepper.advance(down, spec.period_s, HousingInput{d.operating_current_a - kDeltaA, spec.design_ambient_c, 0.0});
  const Eigen::VectorXd gamma_u = (up - down) / (2.0 * kDeltaA);

  // The stationary filter with both readings every period: its stability
  // is the design's detectability check.
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2, n + 2);
  h(0, casing_seen_index(model)) = 1.0;
  h(1, ambient_seen_index(model)) = 1.0;
  Eigen::MatrixXd v = Eigen::MatrixXd::Zero(2, 2);
  v(0, 0) = reading_variance(spec.reading_noise_c, spec.reading_step_c);
  v(1, 1) = reading_variance(spec.ambient_noise_c, spec.reading_step_c);
  const Eigen::MatrixXd prior = solve_dare(f.transpose(), h.transpose(), process_noise(spec, n), v);
  const Eigen::MatrixXd gain = prior * h.transpose() * (h * prior * h.transpose() + v).inverse();
  d.observer_radius = spectral_radius(f * (Eigen::MatrixXd::Identity(n + 2, n + 2) - gain * h));

  // LQ on the held temperature's deviation and the current's.
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(1, n);
  c(0, model.network.casing_sensor.node) = 1.0;
  Eigen::MatrixXd q = c.transpose() * c / (spec.error_scale_c * spec.error_scale_c);
  if (model.network.casing_sensor.node != model.network.tec_to) {
    q(model.network.tec_to, model.network.tec_to) += spec.casing_weight / (spec.error_scale_c * spec.error_scale_c);
  }
  q.diagonal().array() += 1e-9;
  Eigen::MatrixXd r(1, 1);
  r(0, 0) = 1.0 / (spec.current_scale_a * spec.current_scale_a);
  const Eigen::MatrixXd p = solve_dare(phi, gamma_u, q, r);
  const Eigen::MatrixXd bp = gamma_u.transpose() * p;
  d.feedback = (r + bp * gamma_u).ldlt().solve(bp * phi);
  d.loop_radius = spectral_radius(phi - gamma_u * d.feedback);
  if (!(d.observer_radius < 1.0) || !(d.loop_radius < 1.0)) {
    throw std::invalid_argument(text::printf_string(
        "observer loop: not stable at the design point (the filter's spectral radius %.6f, the loop's %.6f; both "
        "must be below 1)",
        d.observer_radius, d.loop_radius));
  }
  return d;
}

ObserverLoop::ObserverLoop(std::shared_ptr<const ObserverLoopDesign> design)
    : design_(std::move(design)), stepper_(design_->model, design_->spec.max_step_s) {
  const int n = design_->model.state_count();
  z_ = Eigen::VectorXd::Zero(n + 2);
  p_ = Eigen::MatrixXd::Zero(n + 2, n + 2);
  f_ = Eigen::MatrixXd::Zero(n + 2, n + 2);
  fp_ = Eigen::MatrixXd::Zero(n + 2, n + 2);
  w_ = process_noise(design_->spec, n);
  h_casing_ = Eigen::VectorXd::Zero(n + 2);
  h_casing_(casing_seen_index(design_->model)) = 1.0;
  h_ambient_ = Eigen::VectorXd::Zero(n + 2);
  h_ambient_(ambient_seen_index(design_->model)) = 1.0;
  gain_ = Eigen::VectorXd::Zero(n + 2);
  x_ = Eigen::VectorXd::Zero(n);
  base_ = Eigen::VectorXd::Zero(n);
  xss_ = Eigen::VectorXd::Zero(n);
  probe_ = Eigen::VectorXd::Zero(n);
  posterior_ = Eigen::VectorXd::Zero(n + 2);
  shadow_z_ = Eigen::VectorXd::Zero(n + 2);
  shadow_p_ = Eigen::MatrixXd::Zero(n + 2, n + 2);
  holding_a_ = design_->operating_current_a;
}

void ObserverLoop::restart(bool keep_heat) noexcept {
  if (!started_ || keep_heat) return;
  shadow_started_ = false;  // from the next reading, on the new estimate
  const int h = heat_index();
  z_(h) = 0.0;
  p_.row(h).setZero();
  p_.col(h).setZero();
  p_(h, h) = initial_heat_var();
}

void ObserverLoop::adopt(const LoopHandover& from) noexcept {
  const HousingModel& m = design_->model;
  const int n = m.state_count();
  start(from.reading_c, from.ambient_reading_c);
  const double casing_c = from.reading_c - m.network.casing_sensor.offset_c;
  const double ambient_c = z_(ambient_index());
  // At a fixed current the held temperature is affine in the heat (the
  // network is linear in the temperatures, the Peltier term too): two steady
  // states give the heat that holds casing_c.
  stepper_.steady_state(xss_, HousingInput{from.current_a, ambient_c, 0.0});
  const double at_zero_c = stepper_.controlled_c(xss_);
  stepper_.steady_state(probe_, HousingInput{from.current_a, ambient_c, 1.0});
  const double per_w = stepper_.controlled_c(probe_) - at_zero_c;
  const double heat_w = std::fabs(per_w) > 1e-12 ? (casing_c - at_zero_c) / per_w : 0.0;
  stepper_.steady_state(xss_, HousingInput{from.current_a, ambient_c, heat_w});
  z_.head(n) = xss_;
  z_(heat_index()) = heat_w;
  posterior_ = z_;
  holding_a_ = from.current_a;
  last_current_a_ = from.current_a;
  shadow_started_ = false;
}

LoopHandover ObserverLoop::handover() const noexcept {
  const model::ThermalNetwork& net = design_->model.network;
  return {controlled_estimate_c() + net.casing_sensor.offset_c,
          posterior_(ambient_index()) + net.ambient_sensor.offset_c, last_current_a_};
}

void ObserverLoop::coast(double current_a) noexcept {
  if (!started_) return;
  posterior_ = z_;
  last_current_a_ = current_a;
  predict(current_a);
  if (shadow_started_) predict_shadow(current_a);
}

void ObserverLoop::start(double reading_c, double ambient_reading_c) noexcept {
  const HousingModel& m = design_->model;
  const int n = m.state_count();
  const double casing_c = reading_c - m.network.casing_sensor.offset_c;
  const double ambient_c =
      std::isfinite(ambient_reading_c) ? ambient_reading_c - m.network.ambient_sensor.offset_c : casing_c;
  z_.head(n).setConstant(casing_c);
  if (m.network.ambient_sensor.node != model::kAmbientNode) z_(m.network.ambient_sensor.node) = ambient_c;
  if (m.has_ambient_lag()) z_(m.ambient_lag_index()) = ambient_c;
  z_(heat_index()) = 0.0;
  z_(ambient_index()) = ambient_c;
  // Loose: the filter learns the nodes it cannot see from the model and the readings.
  p_.setZero();
  p_.diagonal().head(n).setConstant(1.0);
  p_(heat_index(), heat_index()) = initial_heat_var();
  p_(ambient_index(), ambient_index()) = 1.0;
  started_ = true;
}

void ObserverLoop::update(Eigen::VectorXd& z, Eigen::MatrixXd& p, const Eigen::VectorXd& h, double seen_c,
                          double expected_c, double step_c, double noise_var) noexcept {
  gain_.noalias() = p * h;
  const double mean_c = expected_c;
  const double var = h.dot(gain_) + noise_var;  // of the unrounded reading
  double posterior_mean_c = seen_c;
  double posterior_var = noise_var;
  if (step_c > 0.0) {
    // The unrounded reading ~ N(mean_c, var), observed within
    // [seen_c - step/2, seen_c + step/2): a truncated normal's moments.
    const double sd = std::sqrt(var);
    const double alpha = (seen_c - 0.5 * step_c - mean_c) / sd;
    const double beta = (seen_c + 0.5 * step_c - mean_c) / sd;
    // The interval's probability from the tail it lies in: a difference of
    // two values near 1 would lose it all when the reading is a surprise.
    const double mass = alpha > 0.0   ? upper_tail(alpha) - upper_tail(beta)
                        : beta < 0.0 ? upper_tail(-beta) - upper_tail(-alpha)
                                     : 1.0 - upper_tail(-alpha) - upper_tail(beta);
    constexpr double kInvSqrt2Pi = 0.3989422804014327;
    if (mass > 1e-12) {
      const double pdf_a = kInvSqrt2Pi * std::exp(-0.5 * alpha * alpha);
      const double pdf_b = kInvSqrt2Pi * std::exp(-0.5 * beta * beta);
      const double shift = (pdf_a - pdf_b) / mass;
      posterior_mean_c = mean_c + sd * shift;
      posterior_var = var * std::max(1e-6, 1.0 + (alpha * pdf_a - beta * pdf_b) / mass - shift * shift);
    } else {
      // The reading is far outside what the filter expects (a step of the
      // ambient, a model far off): take it as a reading with the step's
      // uniform error, as a plain Kalman filter would.
      const double s = var + step_c * step_c / 12.0;
      z += gain_ * ((seen_c - mean_c) / s);
      p.noalias() -= (gain_ / s) * gain_.transpose();
      symmetrise(p);
      return;
    }
  } else {
    posterior_var = 0.0;
  }
  // (z, y) jointly Gaussian, y's distribution replaced by the posterior's:
  // E[z] moves by P h (E[y] - mean) / var, Cov[z] loses P h h' P (var - Var[y]) / var^2.
  z += gain_ * ((posterior_mean_c - mean_c) / var);
  p.noalias() -= (gain_ * ((var - posterior_var) / (var * var))) * gain_.transpose();
  symmetrise(p);
}

void ObserverLoop::predict(double current_a) noexcept {
  const int n = design_->model.state_count();
  linearise(stepper_, z_, current_a, design_->spec.period_s, f_, base_, x_);
  z_.head(n) = base_;
  fp_.noalias() = f_ * p_;
  p_.noalias() = fp_ * f_.transpose();
  p_ += w_;
  symmetrise(p_);
}

void ObserverLoop::predict_shadow(double current_a) noexcept {
  const int n = design_->model.state_count();
  x_ = shadow_z_.head(n);
  stepper_.advance(x_, design_->spec.period_s,
                   HousingInput{current_a, shadow_z_(ambient_index()), shadow_z_(heat_index())});
  shadow_z_.head(n) = x_;
  fp_.noalias() = f_ * shadow_p_;
  shadow_p_.noalias() = fp_ * f_.transpose();
  shadow_p_ += w_;
  symmetrise(shadow_p_);
}

void ObserverLoop::check_reading(double seen_c, double noise_var) noexcept {
  surprise_ = 0.0;
  if (!shadow_started_ || seen_c != shadow_reading_c_) return;
  const double step_c = design_->spec.reading_step_c;
  gain_.noalias() = shadow_p_ * h_casing_;
  const double sd = std::sqrt(h_casing_.dot(gain_) + noise_var + step_c * step_c / 12.0);
  const double expected_c = h_casing_.dot(shadow_z_);
  const double beyond_c = std::fabs(seen_c - expected_c) - kSurpriseSlackSteps * step_c -
                          kSurpriseModelError * std::fabs(expected_c - shadow_start_c_);
  surprise_ = std::max(0.0, beyond_c / sd);
}

double ObserverLoop::tick(double reading_c, double reading_age_s, double ambient_reading_c, double setpoint_c,
                          double min_a, double max_a) noexcept {
  const ObserverLoopSpec& spec = design_->spec;
  const HousingModel& m = design_->model;
  if (!started_) {
    start(reading_c, ambient_reading_c);
  } else {
    // The model's reading when the sensor measured: from the last tick's
    // estimate over the part of the period before it (the covariance is
    // the tick's: the correction is made now, on the state now).
    const int n = m.state_count();
    double expected_c = h_casing_.dot(z_);
    if (reading_age_s > 0.0) {
      x_ = posterior_.head(n);
      stepper_.advance(x_, std::max(0.0, spec.period_s - reading_age_s),
                       HousingInput{last_current_a_, posterior_(ambient_index()), posterior_(heat_index())});
      expected_c = h_casing_.head(n).dot(x_);
    }
    const double seen_c = reading_c - m.network.casing_sensor.offset_c;
    const double reading_var = quantised_noise_var(spec.reading_noise_c, spec.reading_step_c, spec.noise_floor_steps);
    check_reading(seen_c, reading_var);
    update(z_, p_, h_casing_, seen_c, expected_c, spec.reading_step_c, reading_var);
    if (std::isfinite(ambient_reading_c)) {
      const double ambient_seen_c = ambient_reading_c - m.network.ambient_sensor.offset_c;
      const double ambient_var =
          quantised_noise_var(spec.ambient_noise_c, spec.reading_step_c, spec.noise_floor_steps);
      update(z_, p_, h_ambient_, ambient_seen_c, h_ambient_.dot(z_), spec.reading_step_c, ambient_var);
      if (shadow_started_) {
        update(shadow_z_, shadow_p_, h_ambient_, ambient_seen_c, h_ambient_.dot(shadow_z_), spec.reading_step_c,
               ambient_var);
      }
    }
  }
  // A reading that moved starts the shadow again, from what the filter knows now.
  const double seen_now_c = reading_c - m.network.casing_sensor.offset_c;
  if (!shadow_started_ || seen_now_c != shadow_reading_c_) {
    shadow_z_ = z_;
    shadow_p_ = p_;
    shadow_reading_c_ = seen_now_c;
    shadow_start_c_ = h_casing_.dot(z_);
    shadow_started_ = true;
  }
  posterior_ = z_;
  const int n = m.state_count();
  holding_a_ = steady_current(stepper_, xss_, probe_, setpoint_c, z_(ambient_index()), z_(heat_index()), holding_a_,
                              min_a, max_a);
  // Where no current holds the setpoint (as the filter sees the heat and the
  // ambient now), the one that comes closest: state feedback about the
  // steady state it does reach would steer away from the setpoint.
  const bool holds = std::fabs(stepper_.controlled_c(xss_) - setpoint_c) <= kHoldsC;
  const double wanted_a = holds ? holding_a_ - design_->feedback.dot(z_.head(n) - xss_) : holding_a_;
  const double current_a = std::clamp(wanted_a, min_a, max_a);
  saturated_ = !holds || current_a != wanted_a;
  last_current_a_ = current_a;
  predict(current_a);
  predict_shadow(current_a);
  return current_a;
}

double ObserverLoop::controlled_estimate_c() const noexcept { return stepper_.controlled_c(posterior_); }

}  // namespace gyrotc::control
