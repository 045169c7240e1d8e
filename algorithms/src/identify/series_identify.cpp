#include "gyrotc/algorithms/identify/series_identify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc/algorithms/identify/selection.hpp"

namespace gyrotc::identify {
namespace {

constexpr double kLn10 = 2.302585092994046;
constexpr double kMinLagS = 20.0;
constexpr double kMinRampR0 = 1e-3;  // C/s

// The record averaged into equal bins, with the derived signals.
struct Bins {
  Eigen::VectorXd time_s, temp_c, rate_c_per_s, y, ambient_c, tec_a, tec_a2;
  double step_s = 1.0;  // bin spacing
};

// Centred moving average of half-width h samples (shorter at the ends), by
// cumulative sums: O(n).
std::vector<double> centred_mean(const std::vector<double>& v, std::size_t h) {
  const std::size_t n = v.size();
  std::vector<double> cum(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) cum[i + 1] = cum[i] + v[i];
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= h ? i - h : 0;
    const std::size_t hi = std::min(n - 1, i + h);
    out[i] = (cum[hi + 1] - cum[lo]) / static_cast<double>(hi - lo + 1);
  }
  return out;
}

Bins make_bins(const SeriesRecord& r, const std::vector<double>& y, const SeriesOptions& o) {
  const std::size_t n = r.time_s.size();
  const double dt = (r.time_s.back() - r.time_s.front()) / static_cast<double>(n - 1);
  const auto h = static_cast<std::size_t>(std::max(1.0, std::round(0.5 * o.smooth_s / dt)));
  const std::vector<double> smooth = centred_mean(r.sensor_c, h);
  std::vector<double> rate(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= h ? i - h : 0;
    const std::size_t hi = std::min(n - 1, i + h);
    rate[i] = (smooth[hi] - smooth[lo]) / (r.time_s[hi] - r.time_s[lo]);
  }
  const std::size_t width = (n + o.max_bins - 1) / o.max_bins;
  const std::size_t count = (n + width - 1) / width;
  Bins b;
  for (auto* v : {&b.time_s, &b.temp_c, &b.rate_c_per_s, &b.y, &b.ambient_c, &b.tec_a, &b.tec_a2}) {
    *v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(count));
  }
  const bool has_tec = !r.tec_a.empty();
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t lo = k * width;
    const std::size_t hi = std::min(n, lo + width);
    const auto e = static_cast<Eigen::Index>(k);
    for (std::size_t i = lo; i < hi; ++i) {
      b.time_s(e) += r.time_s[i];
      b.temp_c(e) += smooth[i];
      b.rate_c_per_s(e) += rate[i];
      b.y(e) += y[i];
      b.ambient_c(e) += r.ambient_c[i];
      if (has_tec) {
        b.tec_a(e) += r.tec_a[i];
        b.tec_a2(e) += r.tec_a[i] * r.tec_a[i];
      }
    }
    const double m = static_cast<double>(hi - lo);
    for (auto* v : {&b.time_s, &b.temp_c, &b.rate_c_per_s, &b.y, &b.ambient_c, &b.tec_a, &b.tec_a2}) {
      (*v)(e) /= m;
    }
  }
  b.time_s.array() -= r.time_s.front();
  b.step_s = dt * static_cast<double>(width);
  return b;
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
// intervals + 3 columns written from column `first`.
void spline_columns(const Eigen::VectorXd& x, double lo, double hi, int intervals,
                    Eigen::MatrixXd& design, Eigen::Index first) {
  const double width = (hi - lo) / intervals;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double u = std::clamp((x(i) - lo) / width, 0.0, static_cast<double>(intervals));
    int k = std::min(static_cast<int>(u), intervals - 1);
    const double t = u - k;
    const double s = 1.0 - t;
    design(i, first + k) = s * s * s / 6.0;
    design(i, first + k + 1) = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0;
    design(i, first + k + 2) = (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0;
    design(i, first + k + 3) = t * t * t / 6.0;
  }
}

std::vector<double> log_grid(double lo, double hi, int count) {
  std::vector<double> g;
  for (int i = 0; i < count; ++i) g.push_back(lo + (hi - lo) * (i + 0.5) / count);
  return g;
}


bool has_theta(const std::string& e) {
  return e == "thermal_lag" || e == "ramp_hysteresis" || e == "warm_up";
}
bool has_column(const std::string& e) { return e != "thermal_lag"; }

double se(const Eigen::MatrixXd& cov, Eigen::Index i) { return std::sqrt(std::max(0.0, cov(i, i))); }

struct GyroSetup {
  Bins bins;
  double lo = 0.0, hi = 1.0;
  int intervals = 4;
  double duration_s = 0.0;
};

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
      const double hi = std::log10(std::max(2.0 * kMinRampR0, 0.5 * s.bins.rate_c_per_s.cwiseAbs().maxCoeff()));
      m.theta_lower.push_back(std::log10(kMinRampR0));
      m.theta_upper.push_back(hi);
      axes.push_back(log_grid(std::log10(kMinRampR0), hi, 6));
    } else if (e == "warm_up") {
      const double hi = std::log10(std::max(20.0, s.duration_s / 2.0));
      m.theta_lower.push_back(1.0);
      m.theta_upper.push_back(hi);
      axes.push_back(log_grid(1.0, hi, 8));
    }
  }
  m.theta_grid = grid_product(axes);
  m.evaluate = [&s, effects](const std::vector<double>& theta, Eigen::MatrixXd& design,
                             Eigen::VectorXd& offset) {
    const Bins& b = s.bins;
    const Eigen::Index n = b.y.size();
    Eigen::Index cols = s.intervals + 3;
    for (const auto& e : effects) cols += has_column(e) ? 1 : 0;
    design = Eigen::MatrixXd::Zero(n, cols);
    offset = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd temp = b.temp_c;
    std::size_t t = 0;
    Eigen::Index c = s.intervals + 3;
    for (const auto& e : effects) {
      const double p = has_theta(e) ? std::pow(10.0, theta[t++]) : 0.0;
      if (e == "thermal_lag") {
        temp = first_order_lag(b.temp_c, b.step_s, p);
      } else if (e == "rate_sensitivity") {
        design.col(c++) = b.rate_c_per_s;
      } else if (e == "ramp_hysteresis") {
        design.col(c++) = (b.rate_c_per_s.array() / p).tanh();
      } else if (e == "warm_up") {
        design.col(c++) = (-b.time_s.array() / p).exp();
      } else if (e == "linear_drift") {
        design.col(c++) = b.time_s / 3600.0;
      }
    }
    spline_columns(temp, s.lo, s.hi, s.intervals, design, 0);
  };
  return m;
}

EffectReadout gyro_readout(const GyroSetup& s, const std::string& effect,
                           const std::vector<std::string>& effects, const SeparableFit& fit,
                           const Eigen::MatrixXd& cov) {
  const Eigen::Index n_beta = fit.beta.size();
  Eigen::Index col = s.intervals + 3;
  Eigen::Index th = n_beta;
  for (const auto& e : effects) {
    if (e == effect) break;
    col += has_column(e) ? 1 : 0;
    th += has_theta(e) ? 1 : 0;
  }
  EffectReadout out;
  out.in_bounds = true;
  const auto ratio = [&](Eigen::Index i, double value) {
    const double e = se(cov, i);
    return e > 0 ? std::fabs(value) / e : 1e9;
  };
  if (effect == "thermal_lag") {
    const double tau = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    const double se_log = se(cov, th);
    out.params = {{"tau_s", tau, tau * kLn10 * se_log}};
    out.t_ratio = se_log > 0 ? 1.0 / (kLn10 * se_log) : 1e9;
  } else if (effect == "rate_sensitivity") {
    out.params = {{"k_mv_per_c_per_s", fit.beta(col), se(cov, col)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "ramp_hysteresis") {
    const double r0 = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    out.params = {{"h_mv", fit.beta(col), se(cov, col)},
                  {"r0_c_per_s", r0, r0 * kLn10 * se(cov, th)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "warm_up") {
    const double tau = std::pow(10.0, fit.theta[static_cast<std::size_t>(th - n_beta)]);
    out.params = {{"a_mv", fit.beta(col), se(cov, col)}, {"tau_s", tau, tau * kLn10 * se(cov, th)}};
    out.t_ratio = ratio(col, fit.beta(col));
  } else if (effect == "linear_drift") {
    out.params = {{"d_mv_per_h", fit.beta(col), se(cov, col)}};
    out.t_ratio = ratio(col, fit.beta(col));
  }
  return out;
}

// Number of spline intervals of the baseline bias curve: one per 2 C of the
// record's range (at most 64, and at most a tenth of the bins). Deliberately
// flexible: whatever a curve in T can absorb is absorbed before any effect is
// tried, so effects are claimed only for structure no bias curve can mimic.
int choose_intervals(const GyroSetup& s) {
  constexpr double kIntervalC = 2.0;
  const auto by_range = static_cast<int>(std::ceil((s.hi - s.lo) / kIntervalC));
  const auto by_bins = static_cast<int>(s.bins.y.size() / 10) - 3;
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
    const Eigen::Index n = b.y.size();
    design.resize(n, joule ? 5 : 4);
    design.col(0) = first_order_lag(b.ambient_c, b.step_s, tau);
    design.col(1) = first_order_lag(b.tec_a, b.step_s, tau);
    design.col(2).setOnes();
    design.col(3) = (-b.time_s.array() / tau).exp();
    if (joule) design.col(4) = first_order_lag(b.tec_a2, b.step_s, tau);
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

void check_record(const SeriesRecord& r, SeriesTarget target) {
  const std::size_t n = r.time_s.size();
  if (n < 200) throw std::invalid_argument("a time series needs at least 200 rows");
  if (r.sensor_c.size() != n || r.ambient_c.size() != n ||
      (target == SeriesTarget::gyro_mv && r.gyro_mv.size() != n)) {
    throw std::invalid_argument("columns of unequal length");
  }
  if (target == SeriesTarget::sensor_c && r.tec_a.size() != n) {
    throw std::invalid_argument("target sensor_c needs the tec_a column");
  }
  for (std::size_t i = 1; i < n; ++i) {
    if (!(r.time_s[i] > r.time_s[i - 1])) throw std::invalid_argument("time_s is not increasing");
  }
}

}  // namespace

Identification identify_series(const SeriesRecord& record, SeriesTarget target,
                               const SeriesOptions& options, const Criteria& criteria,
                               const std::function<void(double)>& progress) {
  check_record(record, target);
  const bool gyro = target == SeriesTarget::gyro_mv;
  constexpr int kMinCellsBothWays = 3;
  std::string id_note;
  SelectionProblem problem;
  GyroSetup gyro_setup;
  ThermalSetup thermal_setup;
  const Bins bins = make_bins(record, gyro ? record.gyro_mv : record.sensor_c, options);
  const std::size_t n = static_cast<std::size_t>(bins.y.size());
  problem.y = bins.y;
  if (gyro) {
    gyro_setup.bins = bins;
    if (options.base_die_tau_s > 0.0) {
      Bins& b = gyro_setup.bins;
      const Eigen::VectorXd die = first_order_lag(b.temp_c, b.step_s, options.base_die_tau_s);
      b.rate_c_per_s = (b.temp_c - die) / options.base_die_tau_s;
      b.temp_c = die;
    }
    gyro_setup.lo = gyro_setup.bins.temp_c.minCoeff();
    gyro_setup.hi = std::max(gyro_setup.bins.temp_c.maxCoeff(), gyro_setup.lo + 1e-3);
    gyro_setup.duration_s = record.time_s.back() - record.time_s.front();
    gyro_setup.intervals = choose_intervals(gyro_setup);
    if (cells_crossed_both_ways(gyro_setup.bins) >= kMinCellsBothWays) {
      problem.candidates = {"thermal_lag", "rate_sensitivity", "ramp_hysteresis"};
    } else {
      id_note = "thermal_lag, rate_sensitivity and ramp_hysteresis not tried: the record never "
                "crosses the same temperatures heating and cooling, so a flexible bias curve "
                "absorbs them";
    }
    problem.candidates.push_back("warm_up");
    problem.candidates.push_back("linear_drift");
    problem.build = [&gyro_setup](const std::vector<std::string>& e) { return gyro_model(gyro_setup, e); };
    problem.readout = [&gyro_setup](const std::string& effect, const std::vector<std::string>& effects,
                                    const SeparableFit& fit, const Eigen::MatrixXd& cov) {
      return gyro_readout(gyro_setup, effect, effects, fit, cov);
    };
  } else {
    thermal_setup.bins = bins;
    problem.candidates = {"tec_joule_heating"};
    problem.build = [&thermal_setup](const std::vector<std::string>& e) {
      return thermal_model(thermal_setup, e);
    };
    const double r_th = options.casing_r_th_k_per_w;
    problem.readout = [r_th](const std::string&, const std::vector<std::string>&, const SeparableFit& fit,
                             const Eigen::MatrixXd& cov) {
      EffectReadout out;
      const double k = fit.beta(4);
      out.params = {{"r_ohm", 2.0 * k / r_th, 2.0 * se(cov, 4) / r_th}};
      out.t_ratio = se(cov, 4) > 0 ? std::fabs(k) / se(cov, 4) : 1e9;
      out.in_bounds = k > 0.0 && 2.0 * k / r_th < 50.0;
      return out;
    };
  }
  // Blocked cross-validation: contiguous blocks, every folds-th block held out
  // together, so each fold spans the whole record.
  // Blocks of about cv_block_s (at least 4 per fold) are long against the
  // noise's correlation and short against the record, so an effect confined
  // to the first minutes (warm_up) still has training data in every fold.
  problem.folds = options.folds;
  const double duration = record.time_s.back() - record.time_s.front();
  const auto blocks = static_cast<std::size_t>(
      std::max(4.0 * options.folds, std::round(duration / options.cv_block_s)));
  problem.fold_of.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    problem.fold_of[i] = static_cast<int>((i * blocks / n) % static_cast<std::size_t>(options.folds));
  }
  if (gyro) {
    problem.coverage_key.assign(bins.temp_c.data(), bins.temp_c.data() + n);
  }

  const SelectionResult sel = select_effects(problem, criteria, progress);

  Identification id;
  id.target = gyro ? "gyro_mv" : "sensor_c";
  id.units = gyro ? "mV" : "C";
  id.x_name = "time_s";
  id.note = id_note;
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
  id.regions = regions_of(bins, r0);
  if (id.regions.size() > 5) id.regions.resize(5);
  id.correlations = correlations_of(bins, r0, !record.tec_a.empty());
  id.added = sel.added;
  id.tried = sel.tried;
  id.verdict = sel.verdict;
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
  } else {
    id.effect_signal_name = "dT/dt (C/s)";
    id.effect_signal = to_vec(bins.rate_c_per_s);
  }
  return id;
}

}  // namespace gyrotc::identify
