#include "gyrotc/algorithms/identify/series_identify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc/algorithms/identify/selection.hpp"
#include "gyrotc/algorithms/identify/separating_experiment.hpp"
#include "gyrotc/algorithms/model/effects.hpp"

namespace gyrotc::identify {
namespace {

constexpr double kLn10 = 2.302585092994046;
constexpr double kMinLagS = 20.0;
constexpr double kMinRampR0 = 1e-3;  // C/s

// The record averaged into equal time bins, with the derived signals. Bins
// without samples (inside gaps) hold values interpolated between their
// neighbours so the lag filters run on a uniform grid; `rows` lists the bins
// that are fitted (they hold samples and are not settling after a gap).
struct Bins {
  Eigen::VectorXd time_s, temp_c, rate_c_per_s, y, ambient_c, tec_a, tec_a2, count;
  // dT/dt over SeriesOptions::effect_rate_s: a rate sensitivity's regressor
  // and the argument of a ramp hysteresis' tanh.
  Eigen::VectorXd effect_rate_c_per_s;
  double step_s = 1.0;  // bin width
  std::vector<Eigen::Index> rows;
  int gaps = 0;
  double gap_total_s = 0.0;
};

// Indices where the time step exceeds gap_s: each starts a new segment.
std::vector<std::size_t> segment_starts(const std::vector<double>& t, double gap_s) {
  std::vector<std::size_t> starts{0};
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] - t[i - 1] > gap_s) starts.push_back(i);
  }
  return starts;
}

// Centred moving average over +/- half_s in time within each segment (shorter
// at its ends), by cumulative sums and two pointers; the window's first and
// last samples are returned for the derivative.
struct Window {
  std::vector<double> mean;
  std::vector<std::size_t> lo, hi;
};

Window centred_mean(const std::vector<double>& t, const std::vector<double>& v,
                    const std::vector<std::size_t>& starts, double half_s) {
  const std::size_t n = v.size();
  std::vector<double> cum(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) cum[i + 1] = cum[i] + v[i];
  Window w;
  w.mean.resize(n);
  w.lo.resize(n);
  w.hi.resize(n);
  for (std::size_t s = 0; s < starts.size(); ++s) {
    const std::size_t first = starts[s];
    const std::size_t last = s + 1 < starts.size() ? starts[s + 1] - 1 : n - 1;
    std::size_t lo = first;
    std::size_t hi = first;
    for (std::size_t i = first; i <= last; ++i) {
      while (t[i] - t[lo] > half_s) ++lo;
      while (hi < last && t[hi + 1] - t[i] <= half_s) ++hi;
      w.mean[i] = (cum[hi + 1] - cum[lo]) / static_cast<double>(hi - lo + 1);
      w.lo[i] = lo;
      w.hi[i] = hi;
    }
  }
  return w;
}

double median_step(const std::vector<double>& t) {
  std::vector<double> d(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) d[i - 1] = t[i] - t[i - 1];
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

// Fills bins without samples by linear interpolation between the nearest
// bins with samples (constant beyond the ends).
void interpolate_empty(Eigen::VectorXd& v, const Eigen::VectorXd& count) {
  const Eigen::Index n = v.size();
  Eigen::Index prev = -1;
  for (Eigen::Index i = 0; i <= n; ++i) {
    if (i < n && count(i) == 0.0) continue;
    for (Eigen::Index j = prev + 1; j < i; ++j) {
      if (prev < 0) v(j) = v(i);
      else if (i == n) v(j) = v(prev);
      else v(j) = v(prev) + (v(i) - v(prev)) * static_cast<double>(j - prev) / static_cast<double>(i - prev);
    }
    prev = i;
  }
}

Bins make_bins(const SeriesRecord& r, const std::vector<double>& y, const SeriesOptions& o) {
  const std::size_t n = r.time_s.size();
  const double t0 = r.time_s.front();
  const double span = r.time_s.back() - t0;
  const std::vector<std::size_t> starts = segment_starts(r.time_s, o.gap_s);
  const Window smooth = centred_mean(r.time_s, r.sensor_c, starts, 0.5 * o.smooth_s);
  // The centred difference of the window's means, across the window.
  const auto rate_over = [&](const Window& w) {
    std::vector<double> rate(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t lo = w.lo[i];
      const std::size_t hi = w.hi[i];
      if (hi > lo) rate[i] = (w.mean[hi] - w.mean[lo]) / (r.time_s[hi] - r.time_s[lo]);
    }
    return rate;
  };
  const std::vector<double> rate = rate_over(smooth);
  const std::vector<double> effect_rate =
      rate_over(centred_mean(r.time_s, r.sensor_c, starts, 0.5 * o.effect_rate_s));
  Bins b;
  b.step_s = std::max(median_step(r.time_s), span / static_cast<double>(o.max_bins));
  const auto count = static_cast<Eigen::Index>(std::floor(span / b.step_s)) + 1;
  for (auto* v : {&b.time_s, &b.temp_c, &b.rate_c_per_s, &b.effect_rate_c_per_s, &b.y, &b.ambient_c, &b.tec_a,
                  &b.tec_a2, &b.count}) {
    *v = Eigen::VectorXd::Zero(count);
  }
  const bool has_tec = !r.tec_a.empty();
  for (std::size_t i = 0; i < n; ++i) {
    const auto e = std::min(count - 1, static_cast<Eigen::Index>((r.time_s[i] - t0) / b.step_s));
    b.count(e) += 1.0;
    b.time_s(e) += r.time_s[i] - t0;
    b.temp_c(e) += smooth.mean[i];
    b.rate_c_per_s(e) += rate[i];
    b.effect_rate_c_per_s(e) += effect_rate[i];
    b.y(e) += y[i];
    b.ambient_c(e) += r.ambient_c[i];
    if (has_tec) {
      b.tec_a(e) += r.tec_a[i];
      b.tec_a2(e) += r.tec_a[i] * r.tec_a[i];
    }
  }
  for (Eigen::Index e = 0; e < count; ++e) {
    const double m = b.count(e);
    if (m == 0.0) {
      b.time_s(e) = (static_cast<double>(e) + 0.5) * b.step_s;
      continue;
    }
    for (auto* v : {&b.time_s, &b.temp_c, &b.rate_c_per_s, &b.effect_rate_c_per_s, &b.y, &b.ambient_c, &b.tec_a,
                    &b.tec_a2}) {
      (*v)(e) /= m;
    }
  }
  for (auto* v : {&b.temp_c, &b.ambient_c, &b.tec_a, &b.tec_a2}) interpolate_empty(*v, b.count);
  // Across a gap the temperature is interpolated: its slope is the rate.
  for (Eigen::Index e = 1; e + 1 < count; ++e) {
    if (b.count(e) > 0.0) continue;
    b.rate_c_per_s(e) = (b.temp_c(e + 1) - b.temp_c(e - 1)) / (2.0 * b.step_s);
    b.effect_rate_c_per_s(e) = b.rate_c_per_s(e);
  }
  // Fitted bins: with samples, and not within settle_s after a gap.
  std::vector<double> settle_until;
  for (std::size_t s = 1; s < starts.size(); ++s) {
    ++b.gaps;
    b.gap_total_s += r.time_s[starts[s]] - r.time_s[starts[s] - 1];
    settle_until.push_back(r.time_s[starts[s]] - t0 + o.settle_s);
  }
  std::size_t next_gap = 0;
  for (Eigen::Index e = 0; e < count; ++e) {
    if (b.count(e) == 0.0) continue;
    const double t = b.time_s(e);
    while (next_gap < settle_until.size() && settle_until[next_gap] < t) ++next_gap;
    const bool settling =
        next_gap < settle_until.size() && t >= settle_until[next_gap] - o.settle_s && t <= settle_until[next_gap];
    if (!settling) b.rows.push_back(e);
  }
  return b;
}

Eigen::VectorXd gather(const Eigen::VectorXd& v, const std::vector<Eigen::Index>& rows) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r) out(static_cast<Eigen::Index>(r)) = v(rows[r]);
  return out;
}

// The fitted bins alone (what the residuals are aligned with).
Bins fitted_view(const Bins& grid) {
  Bins f;
  for (auto [to, from] : {std::pair{&f.time_s, &grid.time_s}, {&f.temp_c, &grid.temp_c},
                          {&f.rate_c_per_s, &grid.rate_c_per_s},
                          {&f.effect_rate_c_per_s, &grid.effect_rate_c_per_s}, {&f.y, &grid.y},
                          {&f.ambient_c, &grid.ambient_c},
                          {&f.tec_a, &grid.tec_a}, {&f.tec_a2, &grid.tec_a2}, {&f.count, &grid.count}}) {
    *to = gather(*from, grid.rows);
  }
  f.step_s = grid.step_s;
  f.gaps = grid.gaps;
  f.gap_total_s = grid.gap_total_s;
  for (std::size_t r = 0; r < grid.rows.size(); ++r) f.rows.push_back(static_cast<Eigen::Index>(r));
  return f;
}

// Unit-gain first-order lag of u with time constant tau, exact for u linear
// between samples; starts at equilibrium.
Eigen::VectorXd first_order_lag(const Eigen::VectorXd& u, double step_s, double tau_s) {
  Eigen::VectorXd out(u.size());
  if (u.size() == 0) return out;
  const double decay = std::exp(-step_s / tau_s);
  out(0) = u(0);
  for (Eigen::Index i = 1; i < u.size(); ++i) {
    const double slope_tau = (u(i) - u(i - 1)) / step_s * tau_s;
    out(i) = u(i) - slope_tau + (out(i - 1) - u(i - 1) + slope_tau) * decay;
  }
  return out;
}

// Uniform cubic B-spline basis over [lo, hi] with `intervals` intervals:
// intervals + 3 columns written from column `first`. Beyond the range the
// curve goes on straight, with its slope at the edge: a lagged temperature
// reaches below the fitted bins' range where the coldest (or hottest) part
// of the record was settling after a gap, and a curve held flat there made
// the lag misfit the ramp out of it (issue 31: a 120 s lag behind a 1 h gap
// answered none, its likelihood below the model without it).
void spline_columns(const Eigen::VectorXd& x, double lo, double hi, int intervals,
                    Eigen::MatrixXd& design, Eigen::Index first) {
  const double width = (hi - lo) / intervals;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double u = (x(i) - lo) / width;
    const double inside = std::clamp(u, 0.0, static_cast<double>(intervals));
    const double beyond = u - inside;  // in intervals; 0 within the range
    int k = std::min(static_cast<int>(inside), intervals - 1);
    const double t = inside - k;
    const double s = 1.0 - t;
    design(i, first + k) = s * s * s / 6.0 - beyond * s * s / 2.0;
    design(i, first + k + 1) = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0 + beyond * (3.0 * t * t - 4.0 * t) / 2.0;
    design(i, first + k + 2) =
        (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0 + beyond * (-3.0 * t * t + 2.0 * t + 1.0) / 2.0;
    design(i, first + k + 3) = t * t * t / 6.0 + beyond * t * t / 2.0;
  }
}

std::vector<double> log_grid(double lo, double hi, int count) {
  std::vector<double> g;
  for (int i = 0; i < count; ++i) g.push_back(lo + (hi - lo) * (i + 0.5) / count);
  return g;
}



// Nonlinear parameters of an effect or probe (log10 of a time, each).
int theta_count(const std::string& e) {
  if (e == "thermal_lag" || e == "ramp_hysteresis" || e == "warm_up") return 1;
  if (e == "periodic_structure") return 1;      // the period
  if (e == "level_change_structure") return 2;  // its start and time constant
  return 0;
}

struct GyroSetup {
  Bins bins;
  double lo = 0.0, hi = 1.0;  // temperature range of the fitted bins
  int intervals = 4;
  double duration_s = 0.0;
  double rate_lo = 0.0, rate_hi = 1.0;  // dT/dt range of the fitted bins
  int time_intervals = 4;
  // Monotone records: the trajectory effects cannot be identified, but they
  // still leave structure where dT/dt jumps (a step starting from a hold);
  // the baseline then carries a spline in dT/dt so that structure is not
  // taken for a drift or a warm-up.
  bool rate_nuisance = false;
};

// Columns an effect or probe adds to the design (thermal_lag acts through
// the bias curve's argument instead). Probes are splines without their first
// basis function, which the bias curve's constant already spans.
constexpr int kRateProbeIntervals = 4;
int columns_of(const GyroSetup& s, const std::string& e) {
  if (e == "thermal_lag") return 0;
  if (e == "time_structure") return s.time_intervals + 2;
  if (e == "rate_structure") return kRateProbeIntervals + 2;
  if (e == "tec_structure") return 2;
  if (e == "periodic_structure") return 2;  // sine and cosine
  return 1;
}

// The scanned probes (SelectionProblem::scan): a change of level, a -
// a exp(-(t - t0) / tau) from t0 on (tau short: a step; long: a relaxation),
// starting within 2..98 % of the record, tau from 1 min to an eighth of the
// record (a change that completes within it: a longer one would pass for a
// drift, which the library has);
// a periodic term of 10 min to 40 % of the record (at least 2.5 cycles);
// and the square of the rate (an even function of it, which the library's
// rate effects, odd, do not make).
constexpr double kProbeEdge = 0.02;
constexpr double kMinLevelTauS = 60.0;
constexpr double kMaxLevelTauShare = 0.125;
constexpr double kMinPeriodS = 600.0;
constexpr double kMaxPeriodShare = 0.4;

// Uniform cubic B-spline of x over [lo, hi] without its first basis
// function, into `cols` columns from `first`.
void probe_spline(const Eigen::VectorXd& x, double lo, double hi, int intervals, Eigen::MatrixXd& design,
                  Eigen::Index first) {
  Eigen::MatrixXd basis = Eigen::MatrixXd::Zero(x.size(), intervals + 3);
  spline_columns(x, lo, std::max(hi, lo + 1e-9), intervals, basis, 0);
  design.middleCols(first, intervals + 2) = basis.rightCols(intervals + 2);
}

SeparableModel gyro_model(const GyroSetup& s, const std::vector<std::string>& effects) {
  SeparableModel m;
  std::vector<std::vector<double>> axes;
  for (const auto& e : effects) {
    if (e == "thermal_lag") {
      // Lags much shorter than the smoothing of the 0.0625 C sensor steps
      // (and than the DS18B20's own sampling delay) are not resolvable.
      m.theta_lower.push_back(std::log10(kMinLagS));
      m.theta_upper.push_back(std::log10(3600.0));
      axes.push_back(log_grid(std::log10(kMinLagS), std::log10(3600.0), 8));
    } else if (e == "ramp_hysteresis") {
      // r0 well below the record's fastest rate: a wider tanh is only a
      // rate_sensitivity in disguise.
      // A narrower tanh than the noise of the dT/dt estimate on holds
      // (0.0625 C steps over the smoothing window) is a coin flip.
      const double hi = std::log10(std::max(2.0 * kMinRampR0, 0.5 * std::max(-s.rate_lo, s.rate_hi)));
      m.theta_lower.push_back(std::log10(kMinRampR0));
      m.theta_upper.push_back(hi);
      axes.push_back(log_grid(std::log10(kMinRampR0), hi, 6));
    } else if (e == "warm_up") {
      const double hi = std::log10(std::max(20.0, s.duration_s / 2.0));
      m.theta_lower.push_back(1.0);
      m.theta_upper.push_back(hi);
      axes.push_back(log_grid(1.0, hi, 8));
    } else if (e == "level_change_structure") {
      // Starts come from the scan (SelectionProblem::scan); one grid point
      // keeps the model whole without it.
      const double lo = std::log10(kProbeEdge * s.duration_s);
      const double hi = std::log10((1.0 - kProbeEdge) * s.duration_s);
      m.theta_lower.push_back(lo);
      m.theta_upper.push_back(hi);
      axes.push_back({0.5 * (lo + hi)});
      const double tau_lo = std::log10(kMinLevelTauS);
      const double tau_hi = std::log10(std::max(2.0 * kMinLevelTauS, kMaxLevelTauShare * s.duration_s));
      m.theta_lower.push_back(tau_lo);
      m.theta_upper.push_back(tau_hi);
      axes.push_back({0.5 * (tau_lo + tau_hi)});
    } else if (e == "periodic_structure") {
      const double lo = std::log10(kMinPeriodS);
      const double hi = std::log10(std::max(2.0 * kMinPeriodS, kMaxPeriodShare * s.duration_s));
      m.theta_lower.push_back(lo);
      m.theta_upper.push_back(hi);
      axes.push_back({0.5 * (lo + hi)});
    }
  }
  m.theta_grid = grid_product(axes);
  m.evaluate = [&s, effects](const std::vector<double>& theta, Eigen::MatrixXd& design,
                             Eigen::VectorXd& offset) {
    const Bins& b = s.bins;
    const auto n = static_cast<Eigen::Index>(b.rows.size());
    const Eigen::Index base_cols = s.intervals + 3 + (s.rate_nuisance ? kRateProbeIntervals + 2 : 0);
    Eigen::Index cols = base_cols;
    for (const auto& e : effects) cols += columns_of(s, e);
    design = Eigen::MatrixXd::Zero(n, cols);
    offset = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd temp = gather(b.temp_c, b.rows);
    const Eigen::VectorXd rate = gather(b.rate_c_per_s, b.rows);
    const Eigen::VectorXd time = gather(b.time_s, b.rows);
    std::size_t t = 0;
    Eigen::Index c = base_cols;
    if (s.rate_nuisance) probe_spline(rate, s.rate_lo, s.rate_hi, kRateProbeIntervals, design, s.intervals + 3);
    for (const auto& e : effects) {
      const double p = theta_count(e) > 0 ? std::pow(10.0, theta[t++]) : 0.0;
      const double q = theta_count(e) > 1 ? std::pow(10.0, theta[t++]) : 0.0;
      if (e == "thermal_lag") {
        temp = gather(first_order_lag(b.temp_c, b.step_s, p), b.rows);
      } else if (e == "rate_sensitivity") {
        design.col(c) = gather(b.effect_rate_c_per_s, b.rows);
      } else if (e == "ramp_hysteresis") {
        design.col(c) = (gather(b.effect_rate_c_per_s, b.rows).array() / p).tanh();
      } else if (e == "ambient_sensitivity") {
        design.col(c) = gather(b.ambient_c, b.rows).array() - model::kAmbientReferenceC;
      } else if (e == "warm_up") {
        design.col(c) = (-time.array() / p).exp();
      } else if (e == "linear_drift") {
        design.col(c) = time / 3600.0;
      } else if (e == "time_structure") {
        probe_spline(time, 0.0, s.duration_s, s.time_intervals, design, c);
      } else if (e == "rate_structure") {
        probe_spline(rate, s.rate_lo, s.rate_hi, kRateProbeIntervals, design, c);
      } else if (e == "tec_structure") {
        design.col(c) = gather(b.tec_a, b.rows);
        design.col(c + 1) = gather(b.tec_a2, b.rows);
      } else if (e == "level_change_structure") {
        design.col(c) = (time.array() >= p).select(1.0 - (-(time.array() - p) / q).exp(), 0.0);
      } else if (e == "rate_squared_structure") {
        design.col(c) = (rate * 60.0).array().square().matrix();  // (C/min)^2
      } else if (e == "periodic_structure") {
        const Eigen::ArrayXd phase = time.array() * (2.0 * std::numbers::pi / p);
        design.col(c) = phase.sin().matrix();
        design.col(c + 1) = phase.cos().matrix();
      }
      c += columns_of(s, e);
    }
    spline_columns(temp, s.lo, s.hi, s.intervals, design, 0);
  };
  return m;
}

EffectReadout gyro_readout(const GyroSetup& s, const std::string& effect,
                           const std::vector<std::string>& effects, const SeparableFit& fit,
                           const Eigen::MatrixXd& cov) {
  const Eigen::Index n_beta = fit.beta.size();
  Eigen::Index col = s.intervals + 3 + (s.rate_nuisance ? kRateProbeIntervals + 2 : 0);
  Eigen::Index th = n_beta;
  for (const auto& e : effects) {
    if (e == effect) break;
    col += columns_of(s, e);
    th += theta_count(e);
  }
  EffectReadout out;
  out.in_bounds = true;
  const auto ratio = [&](Eigen::Index i, double value) {
    const double e = standard_error(cov, i);
    return e > 0 ? std::fabs(value) / e : 1e9;
  };
  out.amplitude_index = effect == "thermal_lag" ? th : col;
  if (effect == "thermal_lag") {
    const double tau = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    const double se_log = standard_error(cov, th);
    out.params = {{"tau_s", tau, tau * kLn10 * se_log}};
    out.t_ratio = se_log > 0 ? 1.0 / (kLn10 * se_log) : 1e9;
  } else if (effect == "rate_sensitivity") {
    out.params = {{"k_mv_per_c_per_s", fit.beta(col), standard_error(cov, col)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "ramp_hysteresis") {
    const double r0 = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    out.params = {{"h_mv", fit.beta(col), standard_error(cov, col)},
                  {"r0_c_per_s", r0, r0 * kLn10 * standard_error(cov, th)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "warm_up") {
    const double tau = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    out.params = {{"a_mv", fit.beta(col), standard_error(cov, col)},
                  {"tau_s", tau, tau * kLn10 * standard_error(cov, th)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "ambient_sensitivity") {
    out.params = {{"k_mv_per_c", fit.beta(col), standard_error(cov, col)}, {"ref_c", model::kAmbientReferenceC, 0.0}};
    out.t_ratio = ratio(col, fit.beta(col));
    // Larger than the bias's own temperature slope (~1 mV/C, seed Table 2)
    // is not a plausible coupling of the readout to its surroundings.
    out.in_bounds = std::fabs(fit.beta(col)) <= 5.0;
  } else if (effect == "linear_drift") {
    out.params = {{"d_mv_per_h", fit.beta(col), standard_error(cov, col)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "level_change_structure") {
    // Where it is in the temperature history too: the casing then, and the
    // highest it had been before (a change at a first passage above a
    // temperature shows as casing_c near max_before_c).
    const auto at = [&](Eigen::Index i) { return std::pow(10.0, fit.theta[static_cast<std::size_t>(i - n_beta)]); };
    const double t0 = at(th);
    const Bins& b = s.bins;
    double casing_c = b.temp_c(0);
    double max_before_c = b.temp_c(0);
    for (Eigen::Index i = 0; i < b.time_s.size() && b.time_s(i) < t0; ++i) {
      casing_c = b.temp_c(i);
      max_before_c = std::max(max_before_c, b.temp_c(i));
    }
    out.params = {{"a_mv", fit.beta(col), standard_error(cov, col)},
                  {"t0_s", t0, t0 * kLn10 * standard_error(cov, th)},
                  {"tau_s", at(th + 1), at(th + 1) * kLn10 * standard_error(cov, th + 1)},
                  {"casing_c", casing_c, 0.0},
                  {"max_before_c", max_before_c, 0.0}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "periodic_structure") {
    // The amplitude's joint Wald ratio (sine and cosine); the long-run
    // factor is the larger of the two columns'. Without it the best period of
    // a record with none, the wander's largest excursion, is credited with
    // the wander its refit then lacks, and null records are flagged
    // (docs/IDENTIFY.md, run 4).
    out.amplitude_index = col;
    out.second_amplitude_index = col + 1;
    const Eigen::Vector2d a(fit.beta(col), fit.beta(col + 1));
    const Eigen::Matrix2d c = cov.block(col, col, 2, 2);
    const double amplitude = a.norm();
    const double wald = c.determinant() > 0.0 ? a.dot(c.ldlt().solve(a)) : 1e18;
    const double period = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    out.params = {{"amplitude_mv", amplitude, amplitude > 0.0 ? std::sqrt(a.dot(c * a)) / amplitude : 0.0},
                  {"period_s", period, period * kLn10 * standard_error(cov, th)}};
    out.t_ratio = std::sqrt(std::max(0.0, wald));
  } else if (effect == "rate_squared_structure") {
    out.params = {{"k_mv_per_c2_per_min2", fit.beta(col), standard_error(cov, col)}};
    out.t_ratio = ratio(col, fit.beta(col));
  }
  return out;
}

// A probe's starts from the current model's least-squares residual r (bins
// at times t) and design X: the three best alternatives of its kind by the
// sum of squares its column takes from r with X partialled out (g'r)^2 /
// g'(I - X (X'X)^-1 X')g -- without the partialling a change the bias curve
// has half absorbed would be looked for where the curve could not reach --
// and how many distinguishable alternatives a scan of its kind looks at
// (record / tau per time constant tried; record / 10 min periods).
ProbeScan scan_probe(const GyroSetup& s, const std::string& probe, const Eigen::VectorXd& r,
                     const Eigen::MatrixXd& design) {
  ProbeScan out;
  if (probe == "rate_squared_structure") {
    out.starts = {{}};  // nothing to scan: tested as an effect is
    return out;
  }
  const Eigen::VectorXd t = gather(s.bins.time_s, s.bins.rows);
  const Eigen::Index n = t.size();
  if (n < 10 || design.rows() != n) return out;
  const double duration = s.duration_s;
  // X with unit columns, and the Cholesky factor of X'X (a tiny ridge for
  // the spline's empty intervals).
  Eigen::MatrixXd x = design;
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    const double norm = x.col(j).norm();
    x.col(j) = norm > 0.0 ? Eigen::VectorXd(x.col(j) / norm) : Eigen::VectorXd::Zero(n);
  }
  const Eigen::LDLT<Eigen::MatrixXd> xx(gram_matrix(x) + 1e-9 * Eigen::MatrixXd::Identity(x.cols(), x.cols()));
  struct Found {
    double share;
    std::vector<double> theta;
  };
  std::vector<Found> found;
  // A column the model's own columns (the bias curve above all) take more
  // than 90 % of is one the record cannot tell from them: left out, as its
  // ratio would be noise over almost nothing.
  constexpr double kMinIndependentShare = 0.1;
  const auto in_window = [&](double time) {
    return time >= kProbeEdge * duration && time <= (1.0 - kProbeEdge) * duration;
  };
  if (probe == "level_change_structure") {
    // For each tau, every start t_i at once by backward recursions: with
    // e_j = exp(-(t_j - t_i) / tau), g = 1 - e on j >= i, the sums over j >= i
    // of x_j, x_j e_j, r_j, r_j e_j, e_j and e_j^2.
    out.alternatives = 0.0;
    for (double tau : {120.0, 600.0, 1800.0, 3600.0}) {
      if (tau > kMaxLevelTauShare * duration) continue;
      out.alternatives += duration / tau;
      Eigen::VectorXd sx = Eigen::VectorXd::Zero(x.cols());
      Eigen::VectorXd ex = Eigen::VectorXd::Zero(x.cols());
      double sr = 0.0, er = 0.0, e1 = 0.0, e2 = 0.0;
      for (Eigen::Index i = n - 1; i >= 0; --i) {
        const double decay = i + 1 < n ? std::exp(-(t(i + 1) - t(i)) / tau) : 0.0;
        sx += x.row(i).transpose();
        ex = x.row(i).transpose() + decay * ex;
        sr += r(i);
        er = r(i) + decay * er;
        e1 = 1.0 + decay * e1;
        e2 = 1.0 + decay * decay * e2;
        if (!in_window(t(i))) continue;
        const double gr = sr - er;
        const Eigen::VectorXd xg = sx - ex;
        const double sum_g = static_cast<double>(n - i) - e1;
        const double gg_raw = static_cast<double>(n - i) - 2.0 * e1 + e2;
        const double gg = gg_raw - xg.dot(xx.solve(xg));
        if (gg > kMinIndependentShare * (gg_raw - sum_g * sum_g / static_cast<double>(n))) {
          found.push_back({gr * gr / gg, {std::log10(t(i)), std::log10(tau)}});
        }
      }
    }
  } else if (probe == "periodic_structure") {
    const double max_period = kMaxPeriodShare * duration;
    if (max_period < kMinPeriodS) return out;
    // Frequencies 1 / (2 x record) apart: the LM refines the best.
    const double df = 0.5 / duration;
    out.alternatives = duration * (1.0 / kMinPeriodS - 1.0 / max_period);

    Eigen::MatrixXd g(n, 2);
    for (double f = 1.0 / max_period; f <= 1.0 / kMinPeriodS; f += df) {
      const Eigen::ArrayXd phase = t.array() * (2.0 * std::numbers::pi * f);
      g.col(0) = phase.sin().matrix();
      g.col(1) = phase.cos().matrix();
      const Eigen::MatrixXd xg = x.transpose() * g;
      const Eigen::Matrix2d gg_raw = g.transpose() * g;
      const Eigen::Matrix2d gg = gg_raw - xg.transpose() * xx.solve(xg);
      const Eigen::Vector2d gr = g.transpose() * r;
      const Eigen::LDLT<Eigen::Matrix2d> ggl(gg);
      if (ggl.info() == Eigen::Success && gg.determinant() > kMinIndependentShare * kMinIndependentShare * gg_raw.determinant()) {
        found.push_back({gr.dot(ggl.solve(gr)), {std::log10(1.0 / f)}});
      }
    }
  } else {
    return out;
  }
  std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.share > b.share; });
  // The three best that are not neighbours of a better one (1 % of the
  // record apart in time, 1 / record in frequency).
  for (const Found& f : found) {
    if (out.starts.size() >= 3) break;
    bool near = false;
    for (const auto& st : out.starts) {
      const double a = std::pow(10.0, st[0]);
      const double b = std::pow(10.0, f.theta[0]);
      near = near || (probe == "periodic_structure" ? std::fabs(1.0 / a - 1.0 / b) * duration < 1.0
                                                     : std::fabs(a - b) < 0.01 * duration);
    }
    if (!near) out.starts.push_back(f.theta);
  }
  out.alternatives = std::max(1.0, out.alternatives);
  return out;
}

// Number of spline intervals of the baseline bias curve: one per 2 C of the
// record's range (at most 64, and at most a tenth of the bins). Deliberately
// flexible: whatever a curve in T can absorb is absorbed before any effect is
// tried, so effects are claimed only for structure no bias curve can mimic.
int choose_intervals(const GyroSetup& s) {
  constexpr double kIntervalC = 2.0;
  const auto by_range = static_cast<int>(std::ceil((s.hi - s.lo) / kIntervalC));
  const auto by_bins = static_cast<int>(s.bins.rows.size() / 10) - 3;
  return std::max(2, std::min({by_range, by_bins, 64}));
}

// Effects driven by the temperature trajectory (lag, rate, ramp direction)
// are confounded with the bias curve unless the record crosses the same
// temperatures both heating and cooling: along a monotone history T_die and
// dT/dt are functions of T that a flexible curve absorbs. Counts the 1 C
// cells crossed in both directions.
int cells_crossed_both_ways(const Bins& b) {
  constexpr double kRampCPerS = 0.1 / 60.0;  // faster than 0.1 C/min counts as a ramp
  const double lo = b.temp_c.minCoeff();
  const auto cells = static_cast<std::size_t>(b.temp_c.maxCoeff() - lo) + 1;
  std::vector<char> up(cells, 0);
  std::vector<char> down(cells, 0);
  for (Eigen::Index i = 0; i < b.temp_c.size(); ++i) {
    const auto c = static_cast<std::size_t>(b.temp_c(i) - lo);
    if (b.rate_c_per_s(i) > kRampCPerS) up[c] = 1;
    if (b.rate_c_per_s(i) < -kRampCPerS) down[c] = 1;
  }
  int both = 0;
  for (std::size_t c = 0; c < cells; ++c) both += up[c] && down[c];
  return both;
}

struct ThermalSetup {
  Bins bins;
};

SeparableModel thermal_model(const ThermalSetup& s, const std::vector<std::string>& effects) {
  SeparableModel m;
  m.theta_lower = {1.0};
  m.theta_upper = {std::log10(50000.0)};
  m.theta_grid = grid_product({log_grid(1.0, std::log10(50000.0), 12)});
  const bool joule = !effects.empty();
  m.evaluate = [&s, joule](const std::vector<double>& theta, Eigen::MatrixXd& design,
                           Eigen::VectorXd& offset) {
    const Bins& b = s.bins;
    const double tau = std::pow(10.0, theta[0]);
    const auto n = static_cast<Eigen::Index>(b.rows.size());
    design.resize(n, joule ? 5 : 4);
    design.col(0) = gather(first_order_lag(b.ambient_c, b.step_s, tau), b.rows);
    design.col(1) = gather(first_order_lag(b.tec_a, b.step_s, tau), b.rows);
    design.col(2).setOnes();
    design.col(3) = (-gather(b.time_s, b.rows).array() / tau).exp();
    if (joule) design.col(4) = gather(first_order_lag(b.tec_a2, b.step_s, tau), b.rows);
    offset = Eigen::VectorXd::Zero(n);
  };
  return m;
}

// Residual statistics by kind of segment and by temperature band; worst first.
std::vector<Region> regions_of(const Bins& b, const Eigen::VectorXd& residual) {
  constexpr double kRampCPerS = 0.2 / 60.0;  // faster than 0.2 C/min counts as a ramp
  std::vector<Region> regions;
  const auto add = [&](const std::string& name, const auto& member) {
    Region r;
    r.name = name;
    double sum = 0.0;
    double sum2 = 0.0;
    for (Eigen::Index i = 0; i < residual.size(); ++i) {
      if (!member(i)) continue;
      if (r.samples == 0) r.start = b.time_s(i);
      r.end = b.time_s(i);
      ++r.samples;
      sum += residual(i);
      sum2 += residual(i) * residual(i);
    }
    if (r.samples == 0) return;
    r.mean = sum / static_cast<double>(r.samples);
    r.rms = std::sqrt(sum2 / static_cast<double>(r.samples));
    regions.push_back(r);
  };
  add("first 10 min after power-on", [&](Eigen::Index i) { return b.time_s(i) < 600.0; });
  add("ramps up", [&](Eigen::Index i) { return b.rate_c_per_s(i) > kRampCPerS; });
  add("ramps down", [&](Eigen::Index i) { return b.rate_c_per_s(i) < -kRampCPerS; });
  add("holds", [&](Eigen::Index i) { return std::fabs(b.rate_c_per_s(i)) <= kRampCPerS; });
  const double lo = b.temp_c.minCoeff();
  const double hi = b.temp_c.maxCoeff();
  const double width = (hi - lo) / 4.0;
  for (int k = 0; k < 4 && width > 0.0; ++k) {
    const double a = lo + width * k;
    const double z = k == 3 ? hi + 1e-9 : a + width;
    char name[64];
    std::snprintf(name, sizeof name, "temperature band %.1f..%.1f C", a, z);
    add(name, [&](Eigen::Index i) { return b.temp_c(i) >= a && b.temp_c(i) < z; });
  }
  std::sort(regions.begin(), regions.end(), [](const Region& x, const Region& y) { return x.rms > y.rms; });
  return regions;
}

double pearson(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd ac = a.array() - a.mean();
  const Eigen::VectorXd bc = b.array() - b.mean();
  const double denom = ac.norm() * bc.norm();
  return denom > 0.0 ? ac.dot(bc) / denom : 0.0;
}

std::vector<SignalCorrelation> correlations_of(const Bins& b, const Eigen::VectorXd& residual, bool has_tec) {
  std::vector<SignalCorrelation> out;
  out.push_back({"dT/dt", pearson(residual, b.rate_c_per_s)});
  out.push_back({"sign(dT/dt)", pearson(residual, b.rate_c_per_s.array().sign().matrix())});
  out.push_back({"time since power-on", pearson(residual, b.time_s)});
  out.push_back({"exp(-t/600 s)", pearson(residual, (-b.time_s.array() / 600.0).exp().matrix())});
  if (has_tec) out.push_back({"tec_a^2", pearson(residual, b.tec_a2)});
  return out;
}

void check_record(const SeriesRecord& r, SeriesTarget target, const SeriesOptions& o) {
  const std::size_t n = r.time_s.size();
  if (n < 200) throw std::invalid_argument("a time series needs at least 200 rows");
  if (r.sensor_c.size() != n || r.ambient_c.size() != n ||
      (target == SeriesTarget::gyro_mv && r.gyro_mv.size() != n)) {
    throw std::invalid_argument("columns of unequal length");
  }
  if (target == SeriesTarget::sensor_c && r.tec_a.size() != n) {
    throw std::invalid_argument("target sensor_c needs the tec_a column");
  }
  if (!r.tec_a.empty() && r.tec_a.size() != n) throw std::invalid_argument("columns of unequal length");
  char line[200];
  for (const auto& [name, column] : {std::pair{"time_s", &r.time_s}, {"ambient_c", &r.ambient_c},
                                     {"sensor_c", &r.sensor_c}, {"gyro_mv", &r.gyro_mv}, {"tec_a", &r.tec_a}}) {
    for (std::size_t i = 0; i < column->size(); ++i) {
      if (!std::isfinite((*column)[i])) {
        std::snprintf(line, sizeof line, "%s is not a finite number in data row %zu", name, i + 1);
        throw std::invalid_argument(line);
      }
    }
  }
  for (std::size_t i = 1; i < n; ++i) {
    if (!(r.time_s[i] > r.time_s[i - 1])) throw std::invalid_argument("time_s is not increasing");
  }
  const double step = median_step(r.time_s);
  if (step > o.smooth_s / 3.0) {
    std::snprintf(line, sizeof line,
                  "sampled every %.4g s (median): too coarse for dT/dt, which needs at least 3 samples per "
                  "%.4g s smoothing window",
                  step, o.smooth_s);
    throw std::invalid_argument(line);
  }
  double gaps_s = 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    const double dt = r.time_s[i] - r.time_s[i - 1];
    if (dt <= o.gap_s) continue;
    gaps_s += dt;
    if (target == SeriesTarget::sensor_c && dt > o.settle_s) {
      std::snprintf(line, sizeof line,
                    "gap of %.0f s after time_s %.6g: the casing model cannot carry its state across a gap longer "
                    "than %.0f s; split the record there",
                    dt, r.time_s[i - 1], o.settle_s);
      throw std::invalid_argument(line);
    }
  }
  const double span = r.time_s.back() - r.time_s.front();
  if (gaps_s > 0.5 * span) {
    std::snprintf(line, sizeof line, "gaps cover %.0f s of the %.0f s record: more than half is missing", gaps_s,
                  span);
    throw std::invalid_argument(line);
  }
}

// Whether the casing follows the ambient as a first-order lag, so that
// ambient - T is a multiple of dT/dt and ambient_sensitivity cannot be told
// from rate_sensitivity (the bias curve absorbs the k * T part).
constexpr double kConfoundedCorrelation = 0.98;

// What the record covered (separating_experiment.hpp): the casing's range
// and its ramps.
RecordCoverage coverage_of(const Bins& bins, double duration_s) {
  RecordCoverage c;
  c.low_c = bins.temp_c.minCoeff();
  c.high_c = bins.temp_c.maxCoeff();
  c.duration_s = duration_s;
  const Eigen::Index n = bins.temp_c.size();
  // Moving: faster than a DS18B20 step a minute.
  std::vector<double> ramps;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double per_min = 60.0 * std::fabs(bins.rate_c_per_s(i));
    if (per_min > 0.0625) ramps.push_back(per_min);
  }
  if (!ramps.empty()) {
    std::sort(ramps.begin(), ramps.end());
    c.ramp_slow_c_per_min = ramps[ramps.size() / 10];
    c.ramp_fast_c_per_min = ramps[ramps.size() * 9 / 10];
  }
  return c;
}

}  // namespace

Identification identify_series(const SeriesRecord& record, SeriesTarget target,
                               const SeriesOptions& options, const Criteria& criteria,
                               const std::function<void(double)>& progress) {
  check_record(record, target, options);
  const bool gyro = target == SeriesTarget::gyro_mv;
  constexpr int kMinCellsBothWays = 3;
  constexpr std::size_t kMinFittedBins = 200;
  std::vector<std::string> notes;
  SelectionProblem problem;
  GyroSetup gyro_setup;
  ThermalSetup thermal_setup;
  Bins grid = make_bins(record, gyro ? record.gyro_mv : record.sensor_c, options);
  if (gyro && options.base_die_tau_s > 0.0) {
    const Eigen::VectorXd die = first_order_lag(grid.temp_c, grid.step_s, options.base_die_tau_s);
    grid.rate_c_per_s = (grid.temp_c - die) / options.base_die_tau_s;
    // The die's dT/dt is the casing's through the same lag.
    grid.effect_rate_c_per_s = first_order_lag(grid.effect_rate_c_per_s, grid.step_s, options.base_die_tau_s);
    grid.temp_c = die;
  }
  if (grid.rows.size() < kMinFittedBins) {
    char line[160];
    std::snprintf(line, sizeof line,
                  "only %zu bins left to fit after the gaps and the %.0f s settling after each (at least %zu needed)",
                  grid.rows.size(), options.settle_s, kMinFittedBins);
    throw std::invalid_argument(line);
  }
  if (grid.gaps > 0) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "%d gap(s), %.0f s in all, bridged by interpolating the temperatures; the %.0f s after each are "
                  "not fitted",
                  grid.gaps, grid.gap_total_s, options.settle_s);
    notes.emplace_back(line);
  }
  const Bins bins = fitted_view(grid);
  const std::size_t n = bins.rows.size();
  const double duration = record.time_s.back() - record.time_s.front();
  problem.y = bins.y;
  if (gyro) {
    gyro_setup.bins = grid;
    gyro_setup.lo = bins.temp_c.minCoeff();
    gyro_setup.hi = std::max(bins.temp_c.maxCoeff(), gyro_setup.lo + 1e-3);
    gyro_setup.rate_lo = bins.rate_c_per_s.minCoeff();
    gyro_setup.rate_hi = bins.rate_c_per_s.maxCoeff();
    gyro_setup.duration_s = duration;
    gyro_setup.time_intervals = std::clamp(static_cast<int>(std::round(duration / 3600.0)), 4, 12);
    gyro_setup.intervals = choose_intervals(gyro_setup);
    if (cells_crossed_both_ways(bins) >= kMinCellsBothWays) {
      problem.candidates = {"thermal_lag", "rate_sensitivity", "ramp_hysteresis", "ambient_sensitivity"};
      problem.probes.push_back("rate_structure");
      const double r = std::fabs(pearson(bins.ambient_c - bins.temp_c, bins.rate_c_per_s));
      if (r > kConfoundedCorrelation) {
        problem.confounded.push_back({"rate_sensitivity", "ambient_sensitivity"});
        char line[200];
        std::snprintf(line, sizeof line,
                      "rate_sensitivity and ambient_sensitivity cannot be told apart: the casing follows the "
                      "ambient as a first-order lag (ambient - T correlates %.3f with dT/dt)",
                      r);
        notes.emplace_back(line);
      }
    } else {
      gyro_setup.rate_nuisance = true;
      notes.emplace_back(
          "thermal_lag, rate_sensitivity, ramp_hysteresis and ambient_sensitivity not tried: the record never "
          "crosses the same temperatures heating and cooling, so a flexible bias curve absorbs them (the "
          "baseline carries a spline in dT/dt for what they leave where the rate jumps)");
    }
    problem.candidates.push_back("warm_up");
    // A drift spans every gap, and across a gap the record cannot tell it
    // from the wander (issue 22). It is read from the bias at the same
    // temperature before and after the gap, whose difference the wander
    // makes a free draw of its full variance there; the record knows that
    // variance only from what the flexible bias curve leaves of the wander
    // within the segments, which falls short of it, and refitting the wander
    // after the drift shrinks it further: on null records with a gap a drift
    // would be claimed that the generator's true noise does not support
    // (docs/IDENTIFY.md, run 2).
    if (grid.gaps == 0) {
      problem.candidates.push_back("linear_drift");
    } else {
      notes.emplace_back(
          "linear_drift not tried (nor a change of level, level_change_structure): across a gap the record cannot "
          "tell a drift or a step from the bias wander, whose level change there it knows only from the wander the "
          "bias curve leaves within the segments (record without gaps to test for either)");
    }
    problem.probes.insert(problem.probes.begin(), "time_structure");
    // Structure no catch-all finds under the noise the current model leaves
    // (it takes a step, a relaxation or a periodic term for wander): a change
    // of level (a step, a relaxation after an event), a periodic term, and
    // where the trajectory effects were tried an even function of the rate;
    // each found by a scan and tested as effects are, with its own wander.
    // A change of level is a drift's kin: across a gap it would be read
    // from the wander's free level change there (null records with a 1 h gap
    // were flagged with a 0.2 mV step just before it).
    if (grid.gaps == 0) problem.probes.push_back("level_change_structure");
    problem.probes.push_back("periodic_structure");
    if (!gyro_setup.rate_nuisance) problem.probes.push_back("rate_squared_structure");
    problem.scan = [&gyro_setup](const std::string& probe, const Eigen::VectorXd& residual,
                                 const Eigen::MatrixXd& design) {
      return scan_probe(gyro_setup, probe, residual, design);
    };
    if (!record.tec_a.empty()) {
      const Eigen::VectorXd tec = bins.tec_a.array() - bins.tec_a.mean();
      if (tec.norm() / std::sqrt(static_cast<double>(n)) > 0.01) problem.probes.push_back("tec_structure");
    }
    problem.build = [&gyro_setup](const std::vector<std::string>& e) { return gyro_model(gyro_setup, e); };
    problem.readout = [&gyro_setup](const std::string& effect, const std::vector<std::string>& effects,
                                    const SeparableFit& fit, const Eigen::MatrixXd& cov) {
      return gyro_readout(gyro_setup, effect, effects, fit, cov);
    };
  } else {
    thermal_setup.bins = grid;
    problem.candidates = {"tec_joule_heating"};
    problem.build = [&thermal_setup](const std::vector<std::string>& e) {
      return thermal_model(thermal_setup, e);
    };
    const double r_th = options.casing_r_th_k_per_w;
    problem.readout = [r_th](const std::string&, const std::vector<std::string>&, const SeparableFit& fit,
                             const Eigen::MatrixXd& cov) {
      EffectReadout out;
      // k: the casing's steady rise per A^2 = r_th * r_ohm / 2 (half the Joule heat reaches the casing).
      const double k = fit.beta(4);
      if (r_th > 0.0) out.params.push_back({"r_ohm", 2.0 * k / r_th, 2.0 * standard_error(cov, 4) / r_th});
      out.params.push_back({"rise_k_per_a2", k, standard_error(cov, 4)});
      out.t_ratio = standard_error(cov, 4) > 0 ? std::fabs(k) / standard_error(cov, 4) : 1e9;
      out.in_bounds = k > 0.0 && (r_th <= 0.0 || 2.0 * k / r_th < 50.0);
      out.amplitude_index = 4;
      return out;
    };
  }
  // The noise: white plus a Gauss-Markov wander of the bias, fitted per
  // model. Wander slower than a quarter of the record is left out: it could
  // not be told from the record's own drift.
  problem.time_s.assign(bins.time_s.data(), bins.time_s.data() + n);
  const double mean_count = bins.count.mean();
  for (std::size_t i = 0; i < n; ++i) problem.white_scale.push_back(mean_count / bins.count(static_cast<Eigen::Index>(i)));
  problem.wander_tau_min_s = bins.step_s;
  problem.wander_tau_max_s = std::max(2.0 * bins.step_s, duration / 4.0);
  // Blocked cross-validation: contiguous blocks of about cv_block_s (at least
  // 4 per fold), every folds-th block held out together, so each fold spans
  // the whole record and an effect confined to the first minutes (warm_up)
  // still has training data in every fold. Held-out errors are innovations
  // of the noise model, whose correlation (the long-run variance factor, a
  // few bins) is short against a block even under slow wander.
  problem.folds = options.folds;
  const double block_s = std::min(options.cv_block_s, duration / (4.0 * options.folds));
  problem.fold_of.resize(n);
  problem.unit_of.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto block = static_cast<int>(bins.time_s(static_cast<Eigen::Index>(i)) / block_s);
    problem.unit_of[i] = block;
    problem.fold_of[i] = block % options.folds;
  }
  // Held-out samples the training folds' bias curve would extrapolate to
  // (leverage above 0.2, ten times that of a typical sample) are not scored.
  if (gyro) problem.max_held_out_leverage = 0.2;

  const SelectionResult sel = select_effects(problem, criteria, progress);

  Identification id;
  id.target = gyro ? "gyro_mv" : "sensor_c";
  id.units = gyro ? "mV" : "C";
  id.x_name = "time_s";
  for (const auto& line : notes) id.note += (id.note.empty() ? "" : "; ") + line;
  const Eigen::VectorXd& r0 = sel.baseline.residual;
  const Eigen::VectorXd& r1 = sel.final_fit.residual;
  constexpr std::size_t kLags = 20;
  id.baseline_rms = std::sqrt(r0.squaredNorm() / static_cast<double>(n));
  id.baseline_max_abs = r0.cwiseAbs().maxCoeff();
  id.whiteness_p_before = ljung_box_p({r0.data(), n}, kLags);
  if (gyro) {
    id.baseline_params = {{"spline_intervals", static_cast<double>(gyro_setup.intervals), 0.0}};
  } else {
    id.baseline_params = {{"tau_s", std::pow(10.0, sel.baseline.theta[0]), 0.0}};
  }
  // The noise of the final model, per bin of bin_s.
  id.baseline_params.push_back({"bin_s", bins.step_s, 0.0});
  id.baseline_params.push_back({"white_sd_per_bin", std::sqrt(sel.final_noise.white_var), 0.0});
  id.baseline_params.push_back({"wander_sd", std::sqrt(sel.final_noise.wander_var), 0.0});
  id.baseline_params.push_back({"wander_tau_s", sel.final_noise.tau_s, 0.0});
  id.regions = regions_of(bins, r0);
  if (id.regions.size() > 5) id.regions.resize(5);
  id.correlations = correlations_of(bins, r0, !record.tec_a.empty());
  id.added = sel.added;
  id.tried = sel.tried;
  id.verdict = sel.verdict;
  id.statement = verdict_statement(sel);
  id.unexplained = sel.unexplained;
  id.alternatives = sel.alternatives;
  if (!id.alternatives.empty()) {
    const RecordCoverage coverage = coverage_of(bins, duration);
    for (auto& a : id.alternatives) a.experiment = separating_experiment(a.effect, a.other, coverage);
  }
  if (target == SeriesTarget::gyro_mv) {
    // Bounds of the wander's correlation time (wander_noise.hpp searches
    // within them); at the upper one the wander is as slow as the record
    // lets it be, and what it holds may be structure the model lacks.
    const auto at_bound = [&](const WanderNoise& w, const char* model) {
      char line[240];
      if (w.wander_var > 0.0 && w.tau_s >= 0.99 * problem.wander_tau_max_s) {
        std::snprintf(line, sizeof line,
                      "the %s model's bias wander sits at the bound of its correlation time (%.3g mV over %.0f s, a "
                      "quarter of the record): it may hold structure the model lacks",
                      model, std::sqrt(w.wander_var), w.tau_s);
        id.noise_warnings.emplace_back(line);
      }
    };
    at_bound(sel.baseline_noise, "baseline");
    at_bound(sel.final_noise, "final");
  }
  id.final_rms = std::sqrt(r1.squaredNorm() / static_cast<double>(n));
  id.final_max_abs = r1.cwiseAbs().maxCoeff();
  id.whiteness_p_after = ljung_box_p({r1.data(), n}, kLags);
  id.shrink = id.final_rms > 0 ? id.baseline_rms / id.final_rms : 1.0;
  const auto to_vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  id.x = to_vec(bins.time_s);
  id.measured = to_vec(bins.y);
  id.baseline_model = to_vec(sel.baseline.prediction);
  id.final_model = to_vec(sel.final_fit.prediction);
  const std::string first = sel.added.empty() ? "" : sel.added.front().effect;
  if (!gyro) {
    id.effect_signal_name = "tec_a^2 (A^2)";
    id.effect_signal = to_vec(bins.tec_a2);
  } else if (first == "warm_up" || first == "linear_drift") {
    id.effect_signal_name = "time since power-on (s)";
    id.effect_signal = to_vec(bins.time_s);
  } else if (first == "ambient_sensitivity") {
    id.effect_signal_name = "ambient_c (C)";
    id.effect_signal = to_vec(bins.ambient_c);
  } else {
    id.effect_signal_name = "dT/dt (C/s)";
    id.effect_signal = to_vec(bins.rate_c_per_s);
  }
  return id;
}

}  // namespace gyrotc::identify
