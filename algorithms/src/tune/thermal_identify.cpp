#include "gyrotc/algorithms/tune/thermal_identify.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc/algorithms/identify/separable_fit.hpp"
#include "gyrotc/algorithms/text/printf_string.hpp"

namespace gyrotc::tune {
namespace {

// The screen for a current without effect (identify_thermal's refusal) reads
// the Peltier term's t-ratio against the residual's own Newey-West long-run
// covariance, not against the noise model of the reported standard errors:
// on a fit far above the floor that model takes what the model cannot follow
// for slow noise of hours, and a current that moves the casing by degrees
// would be refused (tune_suite's network 9).
//
// The Newey-West window: Andrews' (1991) AR(1) plug-in for the Bartlett
// kernel, 1.1447 (alpha n)^(1/3), alpha = 4 rho^2 / ((1 - rho)^2 (1 + rho)^2)
// with rho the residual's lag-1 autocorrelation; but at least twice the lag
// at which the residual's autocorrelation has died out (below 0.05): the
// DS18B20's steps are nearly white and hide a slow part (sensor noise with
// its own time constant, what the model does not hold) from rho alone. At
// most a quarter of the record.
std::size_t hac_bandwidth(std::span<const double> residual, double rho) {
  const std::size_t n = residual.size();
  const double alpha = 4.0 * rho * rho / ((1.0 - rho) * (1.0 - rho) * (1.0 + rho) * (1.0 + rho));
  double rows = 1.1447 * std::cbrt(alpha * static_cast<double>(n));
  const std::size_t died_out = identify::decorrelation_lag(residual, 0.05, n / 4);
  rows = std::max(rows, 2.0 * static_cast<double>(died_out));
  return std::clamp<std::size_t>(static_cast<std::size_t>(std::ceil(rows)), 1, std::max<std::size_t>(1, n / 4));
}

// (J'J)^-1 S (J'J)^-1, S = Gamma_0 + sum_l w_l (Gamma_l + Gamma_l') over the
// scores u_t = J_t r_t with Bartlett weights w_l = 1 - l / (L + 1). The
// scores are first summed over blocks of about L / 32 rows (a long bandwidth
// on 1 Hz rows would cost L n k^2), the bandwidth counted in blocks: the
// same long-run covariance up to the within-block weights.
Eigen::MatrixXd hac_covariance(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual,
                               const Eigen::MatrixXd& inverse_normal, std::size_t bandwidth_rows) {
  const Eigen::Index n = jacobian.rows();
  const Eigen::Index k = jacobian.cols();
  const Eigen::Index block = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(bandwidth_rows) / 32);
  const Eigen::Index blocks = (n + block - 1) / block;
  Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(blocks, k);
  for (Eigen::Index t = 0; t < n; ++t) scores.row(t / block) += jacobian.row(t) * residual(t);
  const Eigen::Index lags =
      std::min<Eigen::Index>(blocks - 1, (static_cast<Eigen::Index>(bandwidth_rows) + block - 1) / block);
  Eigen::MatrixXd s = scores.transpose() * scores;
  for (Eigen::Index l = 1; l <= lags; ++l) {
    const double w = 1.0 - static_cast<double>(l) / static_cast<double>(lags + 1);
    const Eigen::MatrixXd gamma = scores.bottomRows(blocks - l).transpose() * scores.topRows(blocks - l);
    s += w * (gamma + gamma.transpose());
  }
  const double dof = static_cast<double>(n) / std::max<double>(1.0, static_cast<double>(n - k));
  return dof * inverse_normal * s * inverse_normal;
}

// A fit's residual as a vector, and its effective sample size (the rows are
// correlated).
std::vector<double> residual_of(const identify::SeparableFit& f) {
  return {f.residual.data(), f.residual.data() + f.residual.size()};
}
double effective_samples_of(const identify::SeparableFit& f) {
  return identify::effective_sample_size(static_cast<std::size_t>(f.residual.size()),
                                         identify::lag1_autocorrelation(residual_of(f)));
}

// The long-run covariance of a fit's searched parameters (hac_covariance, its
// window from the residual) at the model's Jacobian there.
Eigen::MatrixXd long_run_covariance(const Eigen::MatrixXd& jacobian, const identify::SeparableFit& f) {
  const std::vector<double> residual = residual_of(f);
  return hac_covariance(jacobian, f.residual, f.covariance_unscaled,
                        hac_bandwidth(residual, identify::lag1_autocorrelation(residual)));
}

// Record requirements (the experiment takes about 2 h).
constexpr double kMinDurationS = 1800.0;
constexpr double kMaxGapS = 30.0;
constexpr double kMinCurrentRangeA = 0.05;
constexpr double kMinTemperatureRangeC = 0.5;
constexpr double kMaxShareAtLimit = 0.8;
// The sensor's share of the ambient is searched only when the record's
// ambient moved at least this much: against a still room it is one more
// static gain, which the heat rates already are.
constexpr double kMinAmbientRangeForShareC = 3.0;
// Where its search starts: a sensor on a lid or a board with a few percent of
// its conductance to the room (inside the bounds, where the search can move
// either way).
constexpr double kShareGuess = 0.02;
// The first part of a record whose room moved: the identification
// experiment's warm-up and relay, before a chamber's step (2710 s of ~6500).
constexpr double kFirstPartShare = 0.4;
constexpr double kMinPeltierTRatio = 3.0;
// The DS18B20's 1/16 C step as noise: variance step^2 / 12.
constexpr double fit_quantisation_var() { return 0.0625 * 0.0625 / 12.0; }
// Levenberg-Marquardt runs from at most this many starting points.
constexpr std::size_t kMaxRuns = 12;
// Rail "none": a current no stage of this kind delivers.
constexpr double kNoRailA = 50.0;

// The parameter vector theta (what the fit searches).
enum Index : std::size_t {
  kLogPeltier, kLogJoule, kLogLoss, kLogShellRatio, kLogShellTau, kRestRise, kDelay, kLagShare,
  kLogRail, kCasing0, kShell0, kAmbientShare, kLogLimit, kLogSide, kLogSideTau, kAmbient, kCount
};
// The screen for a current without effect: the Peltier term's t-ratio on a
// long-run covariance of the searched parameters (log scale: value / se =
// 1 / se(log); the Peltier term is always searched, first).
double peltier_screen_t(const Eigen::MatrixXd& long_run) {
  return 1.0 / std::max(std::sqrt(std::max(0.0, long_run(kLogPeltier, kLogPeltier))), 1e-300);
}

// No side node: a coupling whose exponential is 0.
constexpr double kNoSide = -1000.0;

// The parameters a search moves: the constant ambient only without an
// ambient column, the sensor's share of the ambient only with one and when
// asked (against a constant ambient that share is one more static offset,
// which the loss and the internal heat already are), the stage's current
// limit and the side node only when asked.
std::vector<std::size_t> searched_parameters(bool ambient_measured, bool sensor_share, bool stage_limit, bool side) {
  std::vector<std::size_t> idx;
  for (std::size_t j = 0; j < kCount; ++j) {
    if (j == kAmbient && ambient_measured) continue;
    if (j == kAmbientShare && !(ambient_measured && sensor_share)) continue;
    if (j == kLogLimit && !stage_limit) continue;
    if ((j == kLogSide || j == kLogSideTau) && !side) continue;
    idx.push_back(j);
  }
  return idx;
}

// Parameters beyond the basic model (the sensor's share of the ambient, the
// stage's current limit, the side node's two) join it when the record asks
// for them: Schwarz's criterion over the residual's effective samples (the
// rows are correlated, and every row counted would take any small gain).
bool parameters_improve_fit(double sse_without, double sse_with, double effective_samples, int added) {
  return effective_samples * std::log(sse_with / sse_without) + added * std::log(effective_samples) < 0.0;
}

// Parameters the data pin down each on their own (strongly correlated pairs
// make the search crawl): the internal heat as the casing's rise above the
// ambient with the TEC off (not against the loss it is divided by), the
// sensor's total delay and the share of it that is a lag, and the rail as the
// current the stage gives at 30 K across the module (not at 0 K, an
// extrapolation along the slope S/R that the Joule term sets).
constexpr double kRailReferenceK = 30.0;

ThermalModel model_of(const std::vector<double>& th) {
  ThermalModel m;
  m.peltier_per_a_s = std::exp(th[kLogPeltier]);
  m.joule_k_per_a2_s = std::exp(th[kLogJoule]);
  m.loss_per_s = std::exp(th[kLogLoss]);
  m.shell_ratio = std::exp(th[kLogShellRatio]);
  m.shell_tau_s = std::exp(th[kLogShellTau]);
  m.internal_k_per_s = th[kRestRise] * m.loss_per_s;
  m.sensor_lag_s = th[kLagShare] * th[kDelay];
  m.dead_time_s = th[kDelay] - m.sensor_lag_s;
  m.sensor_ambient_share = th[kAmbientShare];
  m.rail_a = std::exp(th[kLogRail]) + kRailReferenceK * m.rail_a_per_c();
  m.stage_limit_a = std::exp(th[kLogLimit]);
  m.side_per_s = std::exp(th[kLogSide]);
  m.side_tau_s = std::exp(th[kLogSideTau]);
  return m;
}

// The inverse for the rail: theta's rail parameter for a rail at 0 K.
double rail_parameter(double rail_a, double peltier, double joule) {
  return std::log(std::max(0.02, rail_a - kRailReferenceK * peltier / (2.0 * joule)));
}

void check_record(const TuneRecord& r, double experiment_scale) {
  const std::size_t n = r.time_s.size();
  if (r.sensor_c.size() != n || r.tec_a.size() != n || (!r.ambient_c.empty() && r.ambient_c.size() != n)) {
    throw std::invalid_argument("the record's columns have different lengths");
  }
  if (n < 2) throw std::invalid_argument("the record has fewer than 2 rows");
  for (std::size_t k = 0; k < n; ++k) {
    if (!std::isfinite(r.time_s[k]) || !std::isfinite(r.sensor_c[k]) || !std::isfinite(r.tec_a[k])) {
      throw std::invalid_argument("row " + std::to_string(k + 1) + " has a non-numeric time_s, sensor_c or tec_a");
    }
    if (k > 0 && !(r.time_s[k] > r.time_s[k - 1])) {
      throw std::invalid_argument("time_s does not increase at row " + std::to_string(k + 1));
    }
    if (k > 0 && r.time_s[k] - r.time_s[k - 1] > kMaxGapS) {
      throw std::invalid_argument(
          text::printf_string("a gap of %.0f s in the record at time_s = %.0f: tune needs a continuous "
                              "record (rows at most 30 s apart)",
                              r.time_s[k] - r.time_s[k - 1], r.time_s[k - 1]));
    }
  }
  const double duration = r.time_s.back() - r.time_s.front();
  if (duration < kMinDurationS * experiment_scale) {
    if (experiment_scale == 1.0) {
      throw std::invalid_argument(
          text::printf_string("the record lasts %.0f s; tune needs at least 30 min of the identification "
                              "experiment (`gyrotc record --experiment tune` takes about 2 h)",
                              duration));
    }
    throw std::invalid_argument(
        text::printf_string("the record lasts %.0f s; tune needs at least %.0f s of an identification "
                            "experiment scaled by %.3g (30 min x the scale)",
                            duration, kMinDurationS * experiment_scale, experiment_scale));
  }
  const auto [imin, imax] = std::minmax_element(r.tec_a.begin(), r.tec_a.end());
  if (*imax - *imin < kMinCurrentRangeA) {
    throw std::invalid_argument(
        text::printf_string("no excitation: tec_a stays within %.3f .. %.3f A, so nothing tells the "
                            "current's effect (record `gyrotc record --experiment tune`)",
                            *imin, *imax));
  }
  const auto [tmin, tmax] = std::minmax_element(r.sensor_c.begin(), r.sensor_c.end());
  if (*tmax - *tmin < kMinTemperatureRangeC) {
    throw std::invalid_argument(
        text::printf_string("flat record: sensor_c stays within %.3f .. %.3f C, so the casing did not "
                            "respond to the current (is the TEC connected, the casing sensor the right "
                            "one?)",
                            *tmin, *tmax));
  }
  if (*tmax >= 125.0 || *tmin <= -55.0) {
    throw std::invalid_argument(text::printf_string(
        "saturated record: sensor_c reaches %.1f C, the DS18B20's end of range", *tmax >= 125.0 ? *tmax : *tmin));
  }
  // A current that sits at one extreme for most of the record: the unit never
  // came under the experiment's control (an unreachable setpoint, a stage
  // stuck at its limit).
  for (const double extreme : {*imin, *imax}) {
    if (extreme == 0.0) continue;
    std::size_t at = 0;
    for (double i : r.tec_a) at += std::fabs(i - extreme) <= 0.02 * std::fabs(extreme) ? 1 : 0;
    const double share = static_cast<double>(at) / static_cast<double>(n);
    if (share > kMaxShareAtLimit) {
      throw std::invalid_argument(
          text::printf_string("saturated experiment: tec_a sits at %.3f A in %.0f %% of the rows, so "
                              "the casing never came under the experiment's control (is the setpoint "
                              "reachable at this ambient?)",
                              extreme, 100.0 * share));
    }
  }
}

// A first guess from the one-node heat balance on smoothed derivatives
// (equation error): dT/dt = a I (T + 273.15) + b I^2 - g_ca (T - Ta) + p,
// with the current shift rows earlier than the reading (a sensor that lags
// its node by seconds sees the relay's steps that much later; the balance
// on unshifted rows then mistakes the lag for a weak TEC). The current a
// large command did not get is taken as the rails' (stage_limit false) or as
// the stage's own current limit (true).
std::vector<double> first_guess(const TuneRecord& r, const std::vector<double>& ambient, bool ambient_measured,
                                std::size_t shift, bool stage_limit) {
  const std::size_t n = r.time_s.size();
  constexpr std::size_t w = 10;
  double max_abs = 0.0;
  for (double i : r.tec_a) max_abs = std::max(max_abs, std::fabs(i));
  double mean_ambient = 0.0;
  for (double a : ambient) mean_ambient += a;
  mean_ambient /= static_cast<double>(n);

  struct Row {
    double dtdt, t, i, i2, ta;
    bool steady;  // one command over the window
  };
  std::vector<Row> rows;
  rows.reserve(n);
  for (std::size_t k = w + shift; k + w < n; ++k) {
    Row row{};
    row.steady = true;
    for (std::size_t j = k - w; j < k + w; ++j) {
      const double i = r.tec_a[j - shift];
      row.t += r.sensor_c[j];
      row.i += i;
      row.i2 += i * i;
      row.steady = row.steady && i == r.tec_a[k - shift];
    }
    row.t /= 2.0 * w;
    row.i /= 2.0 * w;
    row.i2 /= 2.0 * w;
    row.dtdt = (r.sensor_c[k + w] - r.sensor_c[k - w]) / (r.time_s[k + w] - r.time_s[k - w]);
    row.ta = ambient_measured ? ambient[k] : mean_ambient;
    rows.push_back(row);
  }
  const double small_a = max_abs / 3.0;
  double a = 1e-4;
  double b = 1e-2;
  double g = 1e-4;
  double c = 0.0;
  double rail = kNoRailA;
  double limit = kNoRailA;
  // Two passes: the heat balance on the rows no rail can clip (heating up to
  // a third of the largest command, and cooling, whose limit moves away while
  // the casing is warmer than the shell), the rail or the limit from the rows
  // that need less current than was commanded; then again without the cooling
  // rows that rail or limit would clip too (a weak stage clips both ways).
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::MatrixXd x(static_cast<Eigen::Index>(rows.size()), 4);
    Eigen::VectorXd y(static_cast<Eigen::Index>(rows.size()));
    Eigen::Index used = 0;
    const double s_guess = a / (2.0 * b);
    for (const Row& row : rows) {
      if (row.i > small_a) continue;
      if (pass == 1 && row.i < -small_a && -row.i > std::min(limit, rail + s_guess * (row.t - row.ta))) continue;
      y(used) = row.dtdt;
      x(used, 0) = row.i * (row.t + kKelvin);
      x(used, 1) = row.i2;
      x(used, 2) = ambient_measured ? -(row.t - row.ta) : -row.t;
      x(used, 3) = 1.0;
      ++used;
    }
    if (used > 8) {
      Eigen::VectorXd beta = identify::solve_linear(x.topRows(used), y.head(used));
      if (!(beta(2) > 0.0)) {
        // The loss came out negative: over rows whose casing stays within a few
        // degrees of one temperature the loss and the constant are nearly one
        // column, and the constant took the loss with a wrong sign. Without
        // the constant (no internal heat) the loss is what the record shows.
        const Eigen::VectorXd no_constant = identify::solve_linear(x.topRows(used).leftCols(3), y.head(used));
        beta.head(3) = no_constant;
        beta(3) = 0.0;
      }
      if (beta(0) > 0.0) a = beta(0);
      b = beta(1) > 0.0 ? beta(1) : 100.0 * a;  // S/R of a few mV/K per ohm
      if (beta(2) > 0.0) g = beta(2);
      c = beta(3);
    }
    const double p_pass = ambient_measured ? c : 0.0;
    double clip_sum = 0.0;
    std::size_t clipped = 0;
    const double s_per_r = a / (2.0 * b);
    for (const Row& row : rows) {
      if (!row.steady || row.i <= small_a) continue;
      // b I^2 + a (T + K) I - (dT/dt + g (T - Ta) - p) = 0, the positive root.
      const double q = row.dtdt + g * (row.t - row.ta) - p_pass;
      const double lin = a * (row.t + kKelvin);
      const double needed = (-lin + std::sqrt(lin * lin + 4.0 * b * q)) / (2.0 * b);
      if (std::isfinite(needed) && needed < 0.95 * row.i) {
        clip_sum += needed + (stage_limit ? 0.0 : s_per_r * (row.t - row.ta));
        ++clipped;
      }
    }
    const double clip_a = clipped > 20 ? clip_sum / static_cast<double>(clipped) : kNoRailA;
    (stage_limit ? limit : rail) = clip_a;
    if (clip_a >= kNoRailA) break;  // nothing clipped: the first pass stands
  }
  const double p = ambient_measured ? c : 0.0;
  const double ta0 = ambient_measured ? mean_ambient : c / g;
  std::vector<double> th(kCount, 0.0);
  th[kLogPeltier] = std::log(a);
  th[kLogJoule] = std::log(b);
  th[kLogLoss] = std::log(g);
  th[kRestRise] = p / g;
  th[kAmbient] = ta0;
  const double shift_s = static_cast<double>(shift) * (r.time_s.back() - r.time_s.front()) / static_cast<double>(n - 1);
  th[kDelay] = shift == 0 ? 1.5 : shift_s;
  th[kLagShare] = shift == 0 ? 0.3 : 0.9;
  th[kCasing0] = r.sensor_c.front();
  th[kShell0] = 0.5 * (r.sensor_c.front() + ta0);
  th[kLogRail] = rail_parameter(std::clamp(rail, 0.05, kNoRailA), a, b);
  th[kLogLimit] = std::log(std::clamp(limit, 0.05, kNoRailA));
  return th;
}

// The identification; on a record the current's screen refuses, and when
// polarity_check, the same record with the current's sign reversed is tried
// too: a TEC wired the wrong way round moves the casing against the command.
ThermalFit identify_record(const TuneRecord& record, double experiment_scale, bool polarity_check);

// The fit of the record with the current reversed, if it is accepted and
// follows the record at most half as far off as the fit as recorded.
std::optional<ThermalFit> reversed_fit(const TuneRecord& record, double experiment_scale, double rms_as_recorded_c) {
  TuneRecord reversed = record;
  for (double& i : reversed.tec_a) i = -i;
  try {
    ThermalFit fit = identify_record(reversed, experiment_scale, false);
    if (fit.rms_c < 0.5 * rms_as_recorded_c) return fit;
  } catch (const std::invalid_argument&) {
    // Not that either.
  }
  return std::nullopt;
}

ThermalFit identify_record(const TuneRecord& record, double experiment_scale, bool polarity_check) {
  check_record(record, experiment_scale);
  const std::size_t n = record.time_s.size();

  // The ambient column, if it has any reading: gaps (no reading yet) take the nearest one.
  bool ambient_measured = false;
  std::vector<double> ambient(n, 0.0);
  if (!record.ambient_c.empty()) {
    double last = std::numeric_limits<double>::quiet_NaN();
    for (double a : record.ambient_c) {
      if (std::isfinite(a)) {
        last = a;
        break;
      }
    }
    ambient_measured = std::isfinite(last);
    for (std::size_t k = 0; k < n; ++k) {
      if (std::isfinite(record.ambient_c[k])) last = record.ambient_c[k];
      ambient[k] = last;
    }
  }

  // First guesses with the current shifted by a ladder of sensor delays.
  const double row_s = (record.time_s.back() - record.time_s.front()) / static_cast<double>(n - 1);
  std::vector<std::vector<double>> guesses;
  std::vector<std::vector<double>> limit_guesses;  // the same with the stage's current limit
  for (double delay_s : {0.0, 4.0, 8.0, 12.0, 20.0, 30.0, 45.0}) {
    const auto shift = static_cast<std::size_t>(std::lround(delay_s / row_s));
    if (delay_s > 0.0 && (shift == 0 || 2 * shift + 40 >= n)) continue;
    guesses.push_back(first_guess(record, ambient, ambient_measured, shift, false));
    limit_guesses.push_back(first_guess(record, ambient, ambient_measured, shift, true));
  }
  const auto [tmin, tmax] = std::minmax_element(record.sensor_c.begin(), record.sensor_c.end());
  double max_command = 0.0;
  for (double i : record.tec_a) max_command = std::max(max_command, std::fabs(i));

  double ambient_range_c = 0.0;
  if (ambient_measured) {
    const auto [amin, amax] = std::minmax_element(ambient.begin(), ambient.end());
    ambient_range_c = *amax - *amin;
  }
  const bool share_searched = ambient_range_c >= kMinAmbientRangeForShareC;

  identify::SeparableModel model;
  // A search runs on the searched parameters (searched_parameters): first
  // without the sensor's share of the ambient, then, where the room moved,
  // with it (below). Every index below kAmbientShare is the same in the full
  // and the searched vectors.
  std::vector<std::size_t> searched = searched_parameters(ambient_measured, false, false, false);
  std::vector<double> full_lower(kCount, 0.0);
  std::vector<double> full_upper(kCount, 0.0);
  auto bound = [&](std::size_t j, double lo, double hi) {
    full_lower[j] = lo;
    full_upper[j] = hi;
  };
  // The full vector (the constant ambient at the first guess's when measured,
  // the sensor's share 0 and no current limit when not searched) and the
  // searched one.
  const double ambient_guess = guesses.front()[kAmbient];
  auto expand = [&](const std::vector<double>& reduced) {
    std::vector<double> full(kCount, 0.0);
    full[kAmbient] = ambient_guess;
    full[kLogLimit] = std::log(kNoRailA);
    full[kLogSide] = kNoSide;
    full[kLogSideTau] = std::log(100.0);
    for (std::size_t j = 0; j < searched.size(); ++j) full[searched[j]] = reduced[j];
    return full;
  };
  auto reduce = [&](const std::vector<double>& full) {
    std::vector<double> reduced(searched.size());
    for (std::size_t j = 0; j < searched.size(); ++j) reduced[j] = full[searched[j]];
    return reduced;
  };
  bound(kLogPeltier, std::log(1e-6), std::log(1e-1));
  bound(kLogJoule, std::log(1e-6), std::log(10.0));
  bound(kLogLoss, std::log(1e-7), std::log(1e-1));
  bound(kLogShellRatio, std::log(0.01), std::log(1000.0));
  bound(kLogShellTau, std::log(2.0), std::log(5000.0));
  bound(kRestRise, -30.0, 60.0);
  bound(kDelay, 0.0, 200.0);
  bound(kLagShare, 0.0, 1.0);
  bound(kLogRail, std::log(0.02), std::log(kNoRailA));
  bound(kCasing0, record.sensor_c.front() - 5.0, record.sensor_c.front() + 5.0);
  bound(kShell0, record.sensor_c.front() - 20.0, record.sensor_c.front() + 20.0);
  bound(kAmbientShare, 0.0, 0.5);
  bound(kLogLimit, std::log(0.02), std::log(kNoRailA));
  bound(kLogSide, std::log(1e-5), std::log(0.1));
  bound(kLogSideTau, std::log(5.0), std::log(3000.0));
  bound(kAmbient, *tmin - 60.0, *tmax + 10.0);
  auto use_parameters = [&](bool sensor_share, bool stage_limit, bool side = false) {
    searched = searched_parameters(ambient_measured, sensor_share, stage_limit, side);
    model.theta_lower = reduce(full_lower);
    model.theta_upper = reduce(full_upper);
  };
  use_parameters(false, false);
  // The first guesses as the current search's vectors, within its bounds.
  auto searched_guesses = [&]() {
    std::vector<std::vector<double>> out;
    for (std::vector<double> guess : guesses) {
      guess[kAmbientShare] = kShareGuess;
      guess = reduce(guess);
      for (std::size_t j = 0; j < searched.size(); ++j) {
        guess[j] = std::clamp(guess[j], model.theta_lower[j], model.theta_upper[j]);
      }
      out.push_back(std::move(guess));
    }
    return out;
  };

  std::vector<double> scratch(n);
  std::vector<double> constant_ambient(n);
  model.evaluate = [&](const std::vector<double>& th, Eigen::MatrixXd& design, Eigen::VectorXd& offset) {
    design.resize(static_cast<Eigen::Index>(n), 0);
    offset.resize(static_cast<Eigen::Index>(n));
    const std::vector<double> full = expand(th);
    const ThermalModel m = model_of(full);
    const ThermalState x0{full[kCasing0], full[kShell0]};
    const std::vector<double>* amb = &ambient;
    if (!ambient_measured) {
      std::fill(constant_ambient.begin(), constant_ambient.end(), full[kAmbient]);
      amb = &constant_ambient;
    }
    simulate_sensor(m, x0, record.time_s, record.tec_a, *amb, std::span<double>(offset.data(), n), scratch);
  };
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t k = 0; k < n; ++k) y(static_cast<Eigen::Index>(k)) = record.sensor_c[k];
  // Starting points. The rail clips the current in a way the Joule term can
  // partly mimic, and the shell is only seen through the casing: the least
  // squares surface has local minima. So first the best of a grid over the
  // Joule term and the rail (the shell at a typical guess) and the best
  // without a rail (the search cannot find a rail it starts far above, where
  // no command reaches it), then a grid over the shell and the sensor's delay
  // from both (the delays scaled to a shifted guess's own). Levenberg-
  // Marquardt runs from the best of these, from the best of the other kind,
  // then from the next best (at most kMaxRuns), until a fit reaches the
  // DS18B20's quantisation floor. That is one search; a record it leaves above
  // the floor gets the sensor-lag stages below.
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  auto sse_of = [&](const std::vector<double>& th) {
    model.evaluate(th, design, offset);
    const double sse = (y - offset).squaredNorm();
    return std::isfinite(sse) ? sse : std::numeric_limits<double>::infinity();
  };
  // The search from one first guess: the grids and the Levenberg-Marquardt runs.
  const double good_sse = 4.0 * fit_quantisation_var() * static_cast<double>(n);
  // A first guess's search vector with the shell at a typical one (a first
  // guess cannot see the shell).
  auto at_typical_shell = [&](const std::vector<double>& guess) {
    std::vector<double> th = guess;
    th[kLogShellRatio] = std::log(5.0);
    th[kLogShellTau] = std::log(80.0);
    return th;
  };
  auto search = [&](const std::vector<double>& start) {
    const std::vector<double> base = at_typical_shell(start);
    const double rail_guess = model_of(expand(start)).rail_a;
    const double rail_scale = rail_guess < 0.9 * kNoRailA ? rail_guess : std::max(0.05, max_command);
    std::vector<double> best_rail = base;
    std::vector<double> best_none = base;
    double best_rail_sse = std::numeric_limits<double>::infinity();
    double best_none_sse = std::numeric_limits<double>::infinity();
    for (double joule : {0.4, 0.63, 1.0, 1.6, 2.5}) {
      for (double rail : {0.6, 0.75, 0.9, 1.0, 1.15, 0.0}) {
        std::vector<double> th = base;
        th[kLogJoule] = start[kLogJoule] + std::log(joule);
        th[kLogRail] = rail_parameter(rail > 0.0 ? rail * rail_scale : kNoRailA, std::exp(th[kLogPeltier]),
                                      std::exp(th[kLogJoule]));
        const double sse = sse_of(th);
        if (rail > 0.0 && sse < best_rail_sse) {
          best_rail_sse = sse;
          best_rail = th;
        }
        if (rail == 0.0 && sse < best_none_sse) {
          best_none_sse = sse;
          best_none = th;
        }
      }
    }
    struct Start {
      std::vector<double> theta;
      double sse;
      bool rail;
    };
    std::vector<Start> starts;
    for (const std::vector<double>* th : {&best_rail, &best_none}) {
      for (double ratio : {1.0, 5.0, 25.0}) {
        for (double tau : {20.0, 80.0, 300.0}) {
          for (double delay : {1.5, 10.0, 40.0}) {
            std::vector<double> trial = *th;
            trial[kLogShellRatio] = std::log(ratio);
            trial[kLogShellTau] = std::log(tau);
            trial[kDelay] = start[kDelay] > 1.5 ? delay * start[kDelay] / 10.0 : delay;
            starts.push_back({trial, sse_of(trial), th == &best_rail});
          }
        }
      }
    }
    std::sort(starts.begin(), starts.end(), [](const Start& a, const Start& b) { return a.sse < b.sse; });
    // The runs: the best start, the best of the other kind (with or without a
    // rail), then the next best, until a fit reaches the quantisation floor.
    std::vector<const Start*> runs{&starts.front()};
    for (const Start& st : starts) {
      if (st.rail != starts.front().rail) {
        runs.push_back(&st);
        break;
      }
    }
    for (const Start& st : starts) {
      if (runs.size() >= kMaxRuns) break;
      if (std::find(runs.begin(), runs.end(), &st) == runs.end()) runs.push_back(&st);
    }
    identify::SeparableFit sf;
    sf.sse = std::numeric_limits<double>::infinity();
    // A fit at the DS18B20's quantisation floor needs no second opinion.
    for (const Start* st : runs) {
      if (sf.sse < good_sse) break;
      model.theta_grid = {st->theta};
      identify::SeparableFit f = identify::fit_separable(y, model);
      if (f.sse < sf.sse) sf = std::move(f);
    }
    return sf;
  };
  // A record whose room moved (a chamber's step, app::tune_experiment_room,
  // after the warm-up and the relay): the fit of its first part alone, a
  // start for the whole record's when that search stays above the floor (the
  // room's step excites what the first guesses' heat balance does not hold,
  // e.g. an ambient sensor on the heat sink). Computed only when needed.
  std::optional<std::vector<double>> still_room_fit;
  bool still_room_tried = false;
  auto fit_first_part = [&]() {
    still_room_tried = true;
    std::size_t k = 0;
    while (k < n && record.time_s[k] - record.time_s.front() < kFirstPartShare * (record.time_s.back() - record.time_s.front())) ++k;
    if (record.time_s[k] - record.time_s.front() >= kMinDurationS * experiment_scale) {
      TuneRecord head;
      head.time_s.assign(record.time_s.begin(), record.time_s.begin() + static_cast<std::ptrdiff_t>(k));
      head.sensor_c.assign(record.sensor_c.begin(), record.sensor_c.begin() + static_cast<std::ptrdiff_t>(k));
      head.tec_a.assign(record.tec_a.begin(), record.tec_a.begin() + static_cast<std::ptrdiff_t>(k));
      head.ambient_c.assign(ambient.begin(), ambient.begin() + static_cast<std::ptrdiff_t>(k));
      try {
        still_room_fit = identify_record(head, experiment_scale, false).theta;
      } catch (const std::invalid_argument&) {
        // That part alone is not enough (e.g. no excitation yet): no such start.
      }
    }
  };

  // The whole search for the current parameters. From the unshifted guess
  // first; when that fit stays above the quantisation floor, from the
  // shifted guess whose simulation follows the record best (a sensor lagging
  // its node by seconds), keeping the better.
  auto full_search = [&]() {
    const std::vector<std::vector<double>> starts = searched_guesses();
    identify::SeparableFit sf = search(starts.front());
    if (sf.sse >= good_sse && starts.size() > 1) {
      std::size_t best = 1;
      double best_sse = std::numeric_limits<double>::infinity();
      for (std::size_t g = 1; g < starts.size(); ++g) {
        const double sse = sse_of(at_typical_shell(starts[g]));
        if (sse < best_sse) {
          best_sse = sse;
          best = g;
        }
      }
      identify::SeparableFit shifted = search(starts[best]);
      if (shifted.sse < sf.sse) sf = std::move(shifted);
    }
    if (sf.sse >= good_sse) {
      // Still above the floor: the heat balance of the best fit so far, its
      // shell and sensor set afresh on a grid of shells and a ladder of sensor
      // lags (a slow shell standing in for a lagging sensor is a basin the
      // searches above can end in), Levenberg-Marquardt from the best four.
      struct Restart {
        std::vector<double> theta;
        double sse;
      };
      std::vector<Restart> restarts;
      for (double ratio : {1.0, 5.0, 25.0}) {
        for (double tau : {20.0, 80.0, 300.0}) {
          for (double lag_s : {3.0, 6.0, 10.0, 15.0, 22.0, 32.0, 45.0, 65.0}) {
            std::vector<double> th = sf.theta;
            th[kLogShellRatio] = std::log(ratio);
            th[kLogShellTau] = std::log(tau);
            th[kLagShare] = 0.9;
            th[kDelay] = lag_s / 0.9;
            restarts.push_back({th, sse_of(th)});
          }
        }
      }
      std::sort(restarts.begin(), restarts.end(), [](const Restart& a, const Restart& b) { return a.sse < b.sse; });
      for (std::size_t k = 0; k < 4 && sf.sse >= good_sse; ++k) {
        model.theta_grid = {restarts[k].theta};
        identify::SeparableFit f = identify::fit_separable(y, model);
        if (f.sse < sf.sse) sf = std::move(f);
      }
    }
    if (sf.sse >= good_sse && share_searched && !still_room_tried) fit_first_part();
    if (sf.sse >= good_sse && still_room_fit) {
      std::vector<double> th = *still_room_fit;
      th[kAmbientShare] = kShareGuess;
      model.theta_grid = {reduce(th)};
      identify::SeparableFit f = identify::fit_separable(y, model);
      if (f.sse < sf.sse) sf = std::move(f);
    }
    return sf;
  };

  // One more parameter (the sensor's share of the ambient, the stage's own
  // current limit): the whole search with it, and Levenberg-Marquardt from
  // the fit without it (from_without: that fit with the new parameter at its
  // guess); the better of the two if it earns its place
  // (parameter_improves_fit), else none and the parameters as they were.
  bool share_fitted = false;
  auto with_parameter = [&](const identify::SeparableFit& without, const std::vector<double>& from_without,
                            bool sensor_share, bool stage_limit) -> std::optional<identify::SeparableFit> {
    use_parameters(sensor_share, stage_limit);
    identify::SeparableFit with = full_search();
    model.theta_grid = {reduce(from_without)};
    identify::SeparableFit refined = identify::fit_separable(y, model);
    if (refined.sse < with.sse) with = std::move(refined);
    if (parameters_improve_fit(without.sse, with.sse, effective_samples_of(with), 1)) return with;
    use_parameters(share_fitted, false);
    return std::nullopt;
  };

  identify::SeparableFit sf = full_search();
  if (share_searched) {
    std::vector<double> from_without = expand(sf.theta);
    from_without[kAmbientShare] = kShareGuess;
    if (std::optional<identify::SeparableFit> with = with_parameter(sf, from_without, true, false)) {
      sf = std::move(*with);
      share_fitted = true;
    }
  }

  // The stage's own current limit: an OPA548 whose ILIM sits below the
  // configured limit gives less than the warm-up's command, at every casing
  // temperature (the rails' limit moves with the difference across the
  // module). A fit still above the floor tries it, its whole search from
  // first guesses that read the clipped rows as a limit: the fit without it
  // has bent the Joule term and the shell to mimic it.
  bool limit_fitted = false;
  if (sf.sse >= good_sse) {
    std::vector<double> from_without = expand(sf.theta);
    from_without[kLogLimit] = limit_guesses.front()[kLogLimit];
    std::swap(guesses, limit_guesses);
    std::optional<identify::SeparableFit> with = with_parameter(sf, from_without, share_fitted, true);
    std::swap(guesses, limit_guesses);
    if (with) {
      sf = std::move(*with);
      limit_fitted = true;
    }
  }

  // A side node on the casing (a board, a lid: a part that takes heat from
  // the casing on the way up and gives it back, which the sensor does not
  // see). A fit still above the floor tries it: Levenberg-Marquardt from that
  // fit with the node set on a grid of couplings and time constants (the best
  // three); it joins the model if its two parameters earn their place. Only
  // with the ambient column: its one user, the model-based loop, needs that
  // column, and without it the room and the casing's heat already trade off.
  bool side_fitted = false;
  const std::vector<double> lumped_theta = expand(sf.theta);  // before the side node's parameters join
  const ThermalModel lumped_model = model_of(lumped_theta);
  if (ambient_measured && sf.sse >= good_sse) {
    use_parameters(share_fitted, limit_fitted, true);
    struct SideStart {
      std::vector<double> theta;
      double sse;
    };
    std::vector<SideStart> side_starts;
    for (double coupling : {3e-4, 1e-3, 3e-3, 1e-2}) {
      for (double tau_s : {30.0, 100.0, 300.0, 1000.0}) {
        std::vector<double> th = lumped_theta;
        th[kLogSide] = std::log(coupling);
        th[kLogSideTau] = std::log(tau_s);
        th = reduce(th);
        const double start_sse = sse_of(th);
        side_starts.push_back({std::move(th), start_sse});
      }
    }
    std::sort(side_starts.begin(), side_starts.end(),
              [](const SideStart& a, const SideStart& b) { return a.sse < b.sse; });
    std::optional<identify::SeparableFit> with;
    for (std::size_t k = 0; k < 3; ++k) {
      model.theta_grid = {side_starts[k].theta};
      identify::SeparableFit f = identify::fit_separable(y, model);
      if (!with || f.sse < with->sse) with = std::move(f);
    }
    // And only if the record pins the node down without losing the TEC: its
    // two parameters within a factor e (one standard error in the log) and
    // the Peltier term still screened (below), on the long-run covariance.
    auto pinned_down = [&] {
      const Eigen::MatrixXd cov =
          long_run_covariance(identify::model_jacobian(model, with->theta, with->beta, nullptr), *with);
      auto sd_at = [&](std::size_t full_index) {
        const auto at = std::find(searched.begin(), searched.end(), full_index) - searched.begin();
        return std::sqrt(std::max(0.0, cov(at, at)));
      };
      return sd_at(kLogSide) < 1.0 && sd_at(kLogSideTau) < 1.0 && peltier_screen_t(cov) > kMinPeltierTRatio;
    };
    if (parameters_improve_fit(sf.sse, with->sse, effective_samples_of(*with), 2) && pinned_down()) {
      sf = std::move(*with);
      side_fitted = true;
    } else {
      use_parameters(share_fitted, limit_fitted);
    }
  }

  ThermalFit fit;
  fit.theta = expand(sf.theta);
  fit.model = model_of(fit.theta);
  fit.initial = {fit.theta[kCasing0], fit.theta[kShell0]};
  fit.ambient_measured = ambient_measured;
  fit.ambient_range_c = ambient_range_c;
  fit.sensor_share_fitted = share_fitted;
  fit.stage_limit_fitted = limit_fitted;
  fit.side_fitted = side_fitted;
  fit.lumped_model = lumped_model;
  fit.ambient_c = ambient_measured ? ambient.front() : fit.theta[kAmbient];
  fit.samples = n;
  fit.duration_s = record.time_s.back() - record.time_s.front();
  fit.prediction.assign(sf.prediction.data(), sf.prediction.data() + n);
  fit.max_command_a = max_command;
  fit.heating_limit_a = *std::max_element(record.tec_a.begin(), record.tec_a.end());
  fit.cooling_limit_a = *std::min_element(record.tec_a.begin(), record.tec_a.end());

  const std::vector<double> residual(sf.residual.data(), sf.residual.data() + n);
  double mean_y = 0.0;
  for (double v : record.sensor_c) mean_y += v;
  mean_y /= static_cast<double>(n);
  double sst = 0.0;
  for (double v : record.sensor_c) sst += (v - mean_y) * (v - mean_y);
  fit.rms_c = std::sqrt(sf.sse / static_cast<double>(n));
  for (double r : residual) fit.max_abs_c = std::max(fit.max_abs_c, std::fabs(r));
  fit.r_squared = sst > 0.0 ? 1.0 - sf.sse / sst : 0.0;
  fit.lag1_autocorrelation = identify::lag1_autocorrelation(residual);
  fit.effective_samples = identify::effective_sample_size(n, fit.lag1_autocorrelation);
  fit.ljung_box_p = identify::ljung_box_p(residual, 20);

  // Covariance of theta: the sandwich under the residual's noise, fitted as
  // white + two first-order parts with the fit's own projection accounted for
  // (residual_noise.hpp); two, because the DS18B20's steps hold while the
  // casing sits still and add a slow part to the sensor's own. The 95 %
  // intervals hold the truth in 95.5 % of the coverage sweeps' 2800
  // (tests/algorithms/tune/standard_error_coverage_test.cpp); a Newey-West
  // window over the residual, which this replaced, missed the slow noise the
  // fit had taken into its curve and held it in 70-80 %.
  const Eigen::MatrixXd jacobian = identify::model_jacobian(model, sf.theta, sf.beta, nullptr);
  fit.noise = fit_residual_noise(jacobian, sf.residual, NoiseParts::two);
  const double screen_t = peltier_screen_t(long_run_covariance(jacobian, sf));
  fit.covariance = Eigen::MatrixXd::Zero(kCount, kCount);
  {
    const Eigen::MatrixXd searched_covariance = noise_covariance(jacobian, sf.covariance_unscaled, fit.noise);
    for (std::size_t i = 0; i < searched.size(); ++i) {
      for (std::size_t j = 0; j < searched.size(); ++j) {
        fit.covariance(static_cast<Eigen::Index>(searched[i]), static_cast<Eigen::Index>(searched[j])) =
            searched_covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      }
    }
  }

  auto sd = [&](std::size_t j) { return std::sqrt(std::max(0.0, fit.covariance(static_cast<Eigen::Index>(j),
                                                                               static_cast<Eigen::Index>(j)))); };
  auto log_estimate = [&](const char* name, const char* unit, std::size_t j) {
    const double v = std::exp(fit.theta[j]);
    Estimate e{name, unit, v, v * sd(j), sd(j) < 0.5, ""};
    if (!e.determined) e.note = "not pinned down by this record";
    return e;
  };
  auto plain_estimate = [&](const char* name, const char* unit, std::size_t j, double scale) {
    Estimate e{name, unit, fit.theta[j], sd(j), sd(j) < scale, ""};
    if (!e.determined) e.note = "not pinned down by this record";
    return e;
  };
  fit.estimates.push_back(log_estimate("peltier_per_a_s", "1/(A s)", kLogPeltier));
  fit.estimates.push_back(log_estimate("joule_k_per_a2_s", "K/(A^2 s)", kLogJoule));
  fit.estimates.push_back(log_estimate("loss_per_s", "1/s", kLogLoss));
  fit.estimates.push_back(log_estimate("shell_ratio", "", kLogShellRatio));
  fit.estimates.push_back(log_estimate("shell_tau_s", "s", kLogShellTau));
  auto derived_estimate = [&](const char* name, const char* unit, const std::function<double(const ThermalModel&)>& f,
                              double scale) {
    Estimate e{name, unit, f(fit.model), std_error_of(fit, f), true, ""};
    e.determined = e.std_error < scale;
    if (!e.determined) e.note = "not pinned down by this record";
    return e;
  };
  fit.estimates.push_back(plain_estimate("rest_rise_c", "K", kRestRise, 5.0));
  fit.estimates.push_back(derived_estimate(
      "internal_k_per_s", "K/s", [](const ThermalModel& m) { return m.internal_k_per_s; },
      std::fabs(fit.model.internal_k_per_s) + 1e-4));
  fit.estimates.push_back(
      derived_estimate("dead_time_s", "s", [](const ThermalModel& m) { return m.dead_time_s; }, 5.0));
  fit.estimates.push_back(
      derived_estimate("sensor_lag_s", "s", [](const ThermalModel& m) { return m.sensor_lag_s; }, 20.0));
  if (share_fitted) {
    fit.estimates.push_back(plain_estimate("sensor_ambient_share", "", kAmbientShare, 0.1));
  }
  // The rail shows only if a command reached it somewhere.
  {
    const ThermalModel& m = fit.model;
    ThermalState x = fit.initial;
    for (std::size_t k = 0; k + 1 < n && !fit.rail_reached; ++k) {
      const double applied = applied_current_a(m, x, record.tec_a[k]);
      fit.rail_reached = std::fabs(applied - record.tec_a[k]) > 0.01;
      x = step(m, x, record.tec_a[k], ambient_measured ? 0.5 * (ambient[k] + ambient[k + 1]) : fit.ambient_c,
               record.time_s[k + 1] - record.time_s[k]);
    }
    Estimate e = derived_estimate("rail_a", "A", [](const ThermalModel& fitted) { return fitted.rail_a; },
                                  0.5 * fit.model.rail_a);
    if (!fit.rail_reached) {
      e.determined = false;
      e.note = "not reached by the record's commands";
    }
    fit.estimates.push_back(e);
  }
  if (limit_fitted) {
    fit.estimates.push_back(derived_estimate(
        "stage_limit_a", "A", [](const ThermalModel& m) { return m.stage_limit_a; }, 0.1 * fit.model.stage_limit_a));
  }
  if (side_fitted) {
    fit.estimates.push_back(log_estimate("side_per_s", "1/s", kLogSide));
    fit.estimates.push_back(log_estimate("side_tau_s", "s", kLogSideTau));
  }
  if (!ambient_measured) fit.estimates.push_back(plain_estimate("ambient_c", "C", kAmbient, 5.0));

  const Estimate& peltier = fit.estimates.front();
  if (!(screen_t > kMinPeltierTRatio) && polarity_check) {
    if (const std::optional<ThermalFit> reversed = reversed_fit(record, experiment_scale, fit.rms_c)) {
      throw std::invalid_argument(text::printf_string(
          "the casing moves against the TEC current: with the current's sign reversed the record fits at "
          "%.3f C rms (as recorded %.3f C): the TEC is wired the wrong way round (swap its leads at the "
          "OPA548's output) and record again",
          reversed->rms_c, fit.rms_c));
    }
  }
  if (!(screen_t > kMinPeltierTRatio) && fit.rms_c > 2.0 * fit.quantisation_rms_c) {
    // A fit far above the floor: the current's effect may be hidden by what
    // the model cannot follow rather than absent; say both.
    throw std::invalid_argument(
        text::printf_string("the TEC current has no measurable effect on the casing temperature beyond what "
                            "the model cannot follow (Peltier term %.3g, %.2g times its standard error; "
                            "residual rms %.3f C, %.0fx the DS18B20's quantisation): is the TEC connected, the "
                            "casing sensor on the casing, and did the experiment run undisturbed?",
                            peltier.value, screen_t, fit.rms_c, fit.rms_c / fit.quantisation_rms_c));
  }
  if (!(screen_t > kMinPeltierTRatio)) {
    throw std::invalid_argument(
        text::printf_string("the TEC current has no measurable effect on the casing temperature (Peltier "
                            "term %.3g, %.2g times its standard error): is the TEC connected and the casing "
                            "sensor on the casing?",
                            peltier.value, screen_t));
  }
  return fit;
}

}  // namespace

ThermalFit identify_thermal(const TuneRecord& record, double experiment_scale) {
  if (!(experiment_scale > 0.0 && experiment_scale <= 1.0)) {
    throw std::invalid_argument(text::printf_string("experiment scale %.3g: must be within (0, 1]", experiment_scale));
  }
  return identify_record(record, experiment_scale, true);
}

double std_error_of(const ThermalFit& fit, const std::function<double(const ThermalModel&)>& f) {
  const double f0 = f(fit.model);
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(kCount);
  for (std::size_t j = kLogPeltier; j < kAmbient; ++j) {
    if (j == kCasing0 || j == kShell0) continue;
    const double sd = std::sqrt(std::max(0.0, fit.covariance(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j))));
    if (!(sd > 0.0) || !std::isfinite(sd)) continue;
    std::vector<double> th = fit.theta;
    const double h = 1e-3 * std::min(sd, 1.0) + 1e-9;
    th[j] += h;
    grad(static_cast<Eigen::Index>(j)) = (f(model_of(th)) - f0) / h;
  }
  const double var = grad.dot(fit.covariance * grad);
  return std::sqrt(std::max(0.0, var));
}

}  // namespace gyrotc::tune
